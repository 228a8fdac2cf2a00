"""How the API's handlers answer: JSON errors of one line, the JSON body of a request, and the
base of the handlers (`Acting`) that asks the Machine for a move, one at a time, and turns its
result or its error into an answer: a result object's fields and `message`, or the
VplotterError's line with the HTTP status of the command's exit status (2: 400, busy 3: 409,
a GPIO backend that cannot start: 503 with `"need": "backend"`, else 500)."""

from __future__ import annotations

import asyncio
import json

from vplotter.web.files import FileError

# what the page needs before it can do what was asked: "position" (the pen's position is
# unknown: set it) or "backend" (the GPIO backend cannot start), in the answer's "need"
NEED_POSITION = ("the pen's position is unknown: put the pen on a point you know (jog it), "
                 "enter that point's X and Y under Position and press Set (`vplotter calibrate "
                 "--at X Y`), then try again")


def error(status: int, message: str, **more):
    from starlette.responses import JSONResponse

    return JSONResponse({"error": message, **more}, status_code=status)


def first_line(text: str) -> str:
    """The first line naming an error, else the last line, else "failed" (at most 500 chars)."""
    lines = [ln.strip() for ln in text.splitlines() if ln.strip()]
    errors = [ln for ln in lines if "error" in ln]
    return (errors[0] if errors else lines[-1] if lines else "failed")[:500]


async def body_json(request) -> dict:
    try:
        data = json.loads(await request.body() or b"{}")
    except ValueError:
        raise FileError(400, "the body must be a JSON object") from None
    if not isinstance(data, dict):
        raise FileError(400, "the body must be a JSON object")
    return data


class Acting:
    """What the handlers share: the server's State, and the moves asked of its Machine."""

    def __init__(self, state):
        self.state = state

    def _busy(self):
        holder = self.state.machine.holder()
        return None if holder is None else error(409, self.state.machine.busy_line(holder))

    async def _need_position(self):
        """The 400 answer (need: position) when no position is stored, else None."""
        st = await asyncio.to_thread(self.state.status)
        if st.get("calibrated", True) is False and not st.get("busy"):
            return error(400, NEED_POSITION, need="position")
        return None

    async def _act(self, do, *args, busy: bool = True, failed=None):
        """do(*args) on a worker thread, one move at a time: (its result, None), or (None, the
        answer): 409 while another process drives the plotter (busy), or the answer to the
        VplotterError it raised (failed(e), by default the command line's status and line)."""
        from vplotter.errors import VplotterError

        async with self.state.acting:
            if busy and (refusal := self._busy()) is not None:
                return None, refusal
            try:
                return await asyncio.to_thread(do, *args), None
            except VplotterError as e:
                return None, (failed or self._failed)(e)

    def _done(self, result, ok: dict, status: int = 200):
        """What a move answers: ok with the result's message (the first line the command
        prints)."""
        from starlette.responses import JSONResponse

        self.state.forget_status()
        return JSONResponse({**ok, "message": result.message.strip()}, status_code=status)

    def _failed(self, e):
        """A VplotterError answered with the command line's exit status (2: 400, busy 3: 409,
        else 500) and its error line; a backend that cannot start is 503, need: backend."""
        from vplotter.errors import BackendError

        self.state.forget_status()
        line = self.state.machine.error_line(e)
        if isinstance(e, BackendError) or getattr(e, "kind", "") == "BackendError":
            return error(503, first_line(line), need="backend")
        status = {2: 400, 3: 409}.get(e.exit_code, 500)
        return error(status, first_line(line) if status != 409 else line.strip().splitlines()[0])
