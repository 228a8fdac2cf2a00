"""The handlers that set the plotter up from the page: what the config says (GET /api/setup),
where the pen is (POST /api/position: `calibrate --at X Y`), `home`, and the pen's pulse
widths saved into config.toml (POST /api/pen/save; POST /api/pen {"state": "cycle", "up_us",
"down_us"} tries them first). The answers are the commands' result values (commands/setup.py).
"""

from __future__ import annotations

import asyncio
import math

from vplotter.web.answers import Acting, body_json, error
from vplotter.web.files import FileError


class SetupHandlers(Acting):
    async def setup(self, request):
        from starlette.responses import JSONResponse

        return JSONResponse(await asyncio.to_thread(self.state.machine.setup))

    async def position(self, request):
        """{"x", "y"}: the pen is now at this G-code point."""
        try:
            data = await body_json(request)
            x, y = (float(data[k]) for k in ("x", "y"))
        except FileError as e:
            return error(e.status, str(e))
        except (KeyError, TypeError, ValueError):
            return error(400, 'give {"x": MM, "y": MM}: the point where the pen is')
        if not all(math.isfinite(v) and abs(v) < 1e5 for v in (x, y)):
            return error(400, "x and y must be numbers of mm (G-code coordinates)")
        placed, answer = await self._act(self.state.machine.place, x, y)
        return answer or self._done(placed, {"x": placed.x, "y": placed.y})

    async def home(self, request):
        if (refusal := self._busy() or await self._need_position()) is not None:
            return refusal
        placed, answer = await self._act(self.state.machine.home)
        return answer or self._done(placed, {"x": placed.x, "y": placed.y})

    async def pen_save(self, request):
        """{"up_us", "down_us"}: written into the config file's [pen]."""
        try:
            data = await body_json(request)
        except FileError as e:
            return error(e.status, str(e))
        widths = [data.get(k) for k in ("up_us", "down_us")]
        if any(isinstance(v, bool) or not isinstance(v, int) for v in widths):
            return error(400, 'give {"up_us": N, "down_us": M}: whole numbers of microseconds')
        saved, answer = await self._act(self.state.machine.save_pen, *widths, busy=False)
        self.state.forget_status()
        return answer or self._done(saved, {"up_us": saved.up_us, "down_us": saved.down_us,
                                            "path": saved.path})
