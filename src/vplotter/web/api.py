"""The JSON API under /api (the page uses nothing else): status, draw, stop, continue, pen,
jog and server-sent events here; the drawings (upload, options, preview) in web/drawings.py,
and setting up (position, home, the pen's widths) in web/setup.py. What touches the plotter
goes through the Machine of commands/serve.py, which answers with values: a result object (its
fields and the `message` the command prints first) or a VplotterError (the command's exit
status and error line); a draw runs as `draw FILE --detach` does, in its own process."""

from __future__ import annotations

import asyncio
import json
import math
import time

from pathlib import Path

from vplotter.web.answers import body_json, error, first_line  # noqa: F401 - app uses error
from vplotter.web.drawings import DrawingHandlers
from vplotter.web.files import FileError
from vplotter.web.queue import QueueHandlers
from vplotter.web.setup import SetupHandlers

STATUS_TTL_S = 0.3         # one status read serves every client asking within this time
EVENT_EVERY_S = 1.0        # an event this often while something drives the plotter
DRAWING_EVERY_S = 0.5      # and while a draw moves (its line: the page grows the drawing)
IDLE_EVERY_S = 10.0        # and at least this often (or at any change) when idle


class State:
    def __init__(self, machine, folder, should_exit):
        self.machine = machine
        self.folder = folder
        self.should_exit = should_exit
        self.acting = asyncio.Lock()         # one move (draw, stop, pen, jog) at a time
        self.working = asyncio.Lock()        # one estimate or preview at a time (CPU)
        self._status = (0.0, None)

    def status(self) -> dict:
        t, st = self._status
        now = time.monotonic()
        if st is None or now - t > STATUS_TTL_S:
            st = self.machine.status()
            self._status = (now, st)
        return st

    def forget_status(self) -> None:
        self._status = (0.0, None)


def routes(state: State):
    from starlette.routing import Route

    h = Handlers(state)
    return [
        Route("/api/status", h.get_status, methods=["GET"]),
        Route("/api/files", h.list_files, methods=["GET"]),
        Route("/api/files", h.upload, methods=["POST"]),
        Route("/api/files/{name}", h.delete_file, methods=["DELETE"]),
        Route("/api/files/{name}/preview.png", h.preview, methods=["GET"]),
        Route("/api/files/{name}/options", h.set_options, methods=["POST"]),
        Route("/api/draw", h.draw, methods=["POST"]),
        Route("/api/stop", h.stop, methods=["POST"]),
        Route("/api/continue", h.go_on, methods=["POST"]),
        Route("/api/pen", h.pen, methods=["POST"]),
        Route("/api/pen/save", h.pen_save, methods=["POST"]),
        Route("/api/position", h.position, methods=["POST"]),
        Route("/api/home", h.home, methods=["POST"]),
        Route("/api/setup", h.setup, methods=["GET"]),
        Route("/api/jog", h.jog, methods=["POST"]),
        Route("/api/events", h.events, methods=["GET"]),
        Route("/api/queue", h.get_queue, methods=["GET"]),
        Route("/api/queue", h.add_job, methods=["POST"]),
        Route("/api/queue/run", h.run_queue, methods=["POST"]),
        Route("/api/queue/{id}", h.remove_job, methods=["DELETE"]),
        Route("/api/queue/{id}/move", h.move_job, methods=["POST"]),
        Route("/api/history", h.get_history, methods=["GET"]),
        Route("/api/now/paths", h.now_paths, methods=["GET"]),
    ]


class Handlers(DrawingHandlers, SetupHandlers, QueueHandlers):
    """The routes' handlers. What moves the plotter is asked of the Machine, whose answers
    are values (result objects with a `message`, or a VplotterError with its exit code)."""

    async def get_status(self, request):
        from starlette.responses import JSONResponse

        return JSONResponse(await asyncio.to_thread(self.state.status))

    # ------------------------------------------------------------ moving the plotter
    async def draw(self, request):
        try:
            data = await body_json(request)
            resume = bool(data.get("resume", False))
            if data.get("file") is None and resume:
                stored = (await asyncio.to_thread(self.state.status)).get("resume") or {}
                if not stored.get("file"):
                    return error(400, "nothing to resume: no interrupted draw is stored")
                path = stored["file"]
            else:
                path = str(self.state.folder.file(str(data.get("file", ""))))
        except FileError as e:
            return error(e.status, str(e))
        if (refusal := self._busy() or await self._need_position()) is not None:
            return refusal
        # a file of the upload folder is drawn with the options kept for it
        here = Path(path).parent == self.state.folder.path
        kept = self.options(Path(path).name) if here else {}
        started, answer = await self._act(self.state.machine.draw, path, resume, kept)
        return answer or self._done(started, {"pid": started.pid}, 202)

    async def stop(self, request):
        stopped, answer = await self._act(self.state.machine.stop, busy=False)
        return answer or self._done(stopped, {"stopped": stopped.pid is not None})

    async def go_on(self, request):
        def nothing_waits(e):              # the state says otherwise: a conflict
            if e.exit_code != 2:
                return self._failed(e)
            line = self.state.machine.error_line(e)
            return error(409, first_line(line).removeprefix("vplotter: "))

        went, answer = await self._act(self.state.machine.continue_, busy=False,
                                       failed=nothing_waits)
        return answer or self._done(went, {"continued": True})

    async def pen(self, request):
        try:
            data = await body_json(request)
        except FileError as e:
            return error(e.status, str(e))
        if data.get("state") not in ("up", "down", "cycle"):
            return error(400, 'give {"state": "up"}, {"state": "down"} or {"state": "cycle"}')
        widths = [data.get(k) for k in ("up_us", "down_us")]
        if any(v is not None and (isinstance(v, bool) or not isinstance(v, int)) for v in widths):
            return error(400, "up_us and down_us must be whole numbers of microseconds")
        moved, answer = await self._act(self.state.machine.pen, data["state"], *widths)
        return answer or self._done(moved, {"pen": data["state"]})

    async def jog(self, request):
        try:
            data = await body_json(request)
            dx, dy = (float(data.get(k, 0.0)) for k in ("dx", "dy"))
        except FileError as e:
            return error(e.status, str(e))
        except (TypeError, ValueError):
            return error(400, 'give {"dx": MM, "dy": MM}')
        if not all(math.isfinite(v) and abs(v) <= 1000 for v in (dx, dy)) or dx == dy == 0:
            return error(400, "dx and dy must be numbers of mm up to 1000, not both 0")
        moved, answer = await self._act(self.state.machine.jog, dx, dy)
        return answer or self._done(moved, {"dx": dx, "dy": dy})

    # ------------------------------------------------------------ events
    async def events(self, request):
        from starlette.responses import StreamingResponse

        state = self.state

        async def stream():
            last, sent = None, 0.0
            while not state.should_exit():
                st = await asyncio.to_thread(state.status)
                now = time.monotonic()
                d = st.get("drawing") or {}
                key = (st.get("busy"), d.get("state"), st.get("last_stop"), st.get("resume"),
                       st.get("pen"), st.get("x_mm"), st.get("y_mm"))
                every = (DRAWING_EVERY_S if d.get("state") == "drawing" else
                         EVENT_EVERY_S if st.get("busy") else IDLE_EVERY_S)
                if key != last or now - sent >= every:
                    yield f"data: {json.dumps(st)}\n\n"
                    last, sent = key, now
                await asyncio.sleep(0.25)

        return StreamingResponse(stream(), media_type="text/event-stream",
                                 headers={"Cache-Control": "no-store", "X-Accel-Buffering": "no"})
