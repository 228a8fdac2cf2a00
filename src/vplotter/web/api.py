"""The JSON API under /api (the page uses nothing else): status, files, draw, stop, pen, jog,
and server-sent events. What touches the plotter goes through the Machine of
commands/serve.py, which answers with values: a result object (its fields and the `message`
the command prints first) or a VplotterError (the command's exit status and error line); a
draw runs as `draw FILE --detach` does, in its own process."""

from __future__ import annotations

import asyncio
import json
import math
import time

from vplotter.web.files import MAX_BYTES, FileError

STATUS_TTL_S = 0.3         # one status read serves every client asking within this time
EVENT_EVERY_S = 1.0        # an event this often while something drives the plotter
IDLE_EVERY_S = 10.0        # and at least this often (or at any change) when idle


def error(status: int, message: str):
    from starlette.responses import JSONResponse

    return JSONResponse({"error": message}, status_code=status)


def first_line(text: str) -> str:
    """The first line naming an error, else the last line, else "failed" (at most 500 chars)."""
    lines = [ln.strip() for ln in text.splitlines() if ln.strip()]
    errors = [ln for ln in lines if "error" in ln]
    return (errors[0] if errors else lines[-1] if lines else "failed")[:500]


class TooBig(Exception):
    pass


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
        Route("/api/draw", h.draw, methods=["POST"]),
        Route("/api/stop", h.stop, methods=["POST"]),
        Route("/api/continue", h.go_on, methods=["POST"]),
        Route("/api/pen", h.pen, methods=["POST"]),
        Route("/api/jog", h.jog, methods=["POST"]),
        Route("/api/events", h.events, methods=["GET"]),
    ]


async def body_json(request) -> dict:
    try:
        data = json.loads(await request.body() or b"{}")
    except ValueError:
        raise FileError(400, "the body must be a JSON object") from None
    if not isinstance(data, dict):
        raise FileError(400, "the body must be a JSON object")
    return data


async def _limited(request):
    """The request's body, refused (TooBig) past the upload limit while it streams."""
    n = 0
    async for chunk in request.stream():
        n += len(chunk)
        if n > MAX_BYTES + 65536:
            raise TooBig
        yield chunk


class Handlers:
    """The routes' handlers. What moves the plotter is asked of the Machine, whose answers
    are values (result objects with a `message`, or a VplotterError with its exit code)."""

    def __init__(self, state: State):
        self.state = state

    # ------------------------------------------------------------ status and files
    async def get_status(self, request):
        from starlette.responses import JSONResponse

        return JSONResponse(await asyncio.to_thread(self.state.status))

    async def list_files(self, request):
        from starlette.responses import JSONResponse

        return JSONResponse(self.state.folder.listing())

    async def upload(self, request):
        from starlette.formparsers import MultiPartException, MultiPartParser
        from starlette.responses import JSONResponse

        declared = request.headers.get("content-length")
        if declared is not None and declared.isdigit() and int(declared) > MAX_BYTES + 65536:
            return error(413, f"the file is larger than {MAX_BYTES >> 20} MB")
        if not request.headers.get("content-type", "").startswith("multipart/form-data"):
            return error(400, "send the file as multipart/form-data in the field `file`")
        try:
            form = await MultiPartParser(request.headers, _limited(request), max_files=1,
                                         max_fields=4).parse()
        except TooBig:
            return error(413, f"the file is larger than {MAX_BYTES >> 20} MB")
        except MultiPartException as e:
            return error(400, f"not a file upload: {e.message}")
        try:
            up = form.get("file")
            if up is None or isinstance(up, str) or not up.filename:
                return error(400, "no file in the field `file`")
            if (up.size or 0) > MAX_BYTES:
                return error(413, f"the file is larger than {MAX_BYTES >> 20} MB")
            async with self.state.working:
                kept = await self._keep(up)
                if not isinstance(kept, tuple):
                    return kept
                name, estimate_s = kept
        except FileError as e:
            return error(e.status, str(e))
        finally:
            await form.close()
        return JSONResponse({"name": name, "estimate_s": round(estimate_s, 1)}, status_code=201)

    async def _keep(self, up):
        """Write the upload inside the folder, estimate it, keep it: (name, estimate_s), or
        the 400 answer of a file that does not validate (nothing is kept)."""
        from vplotter.errors import VplotterError

        folder = self.state.folder
        tmp = folder.incoming(up.filename)
        try:
            await up.seek(0)
            with open(tmp, "wb") as out:
                while block := await up.read(1 << 20):
                    out.write(block)
            estimate_s = await asyncio.to_thread(self.state.machine.estimate, str(tmp))
        except Exception as e:
            folder.discard(tmp)
            if isinstance(e, VplotterError):
                return error(400, first_line(str(e).replace(str(tmp.parent) + "/", "")))
            raise
        return folder.keep(tmp, estimate_s), estimate_s

    async def delete_file(self, request):
        from starlette.responses import JSONResponse

        try:
            self.state.folder.delete(request.path_params["name"])
        except FileError as e:
            return error(e.status, str(e))
        return JSONResponse({"deleted": request.path_params["name"]})

    async def preview(self, request):
        from starlette.responses import Response

        state = self.state
        try:
            path = state.folder.file(request.path_params["name"])
        except FileError as e:
            return error(e.status, str(e))
        png = state.folder.preview_path(path.name)
        async with state.working:
            if not png.exists() or png.stat().st_mtime_ns < path.stat().st_mtime_ns:
                code, err = await asyncio.to_thread(state.machine.preview, str(path), str(png))
                if code != 0 or not png.exists():
                    return error(400 if code == 2 else 500, first_line(err))
        return Response(png.read_bytes(), media_type="image/png",
                        headers={"Cache-Control": "no-cache"})

    # ------------------------------------------------------------ moving the plotter
    def _busy(self):
        holder = self.state.machine.holder()
        return None if holder is None else error(409, self.state.machine.busy_line(holder))

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
        else 500) and its error line."""
        self.state.forget_status()
        status = {2: 400, 3: 409}.get(e.exit_code, 500)
        line = self.state.machine.error_line(e)
        return error(status, first_line(line) if status != 409 else line.strip().splitlines()[0])

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
        started, answer = await self._act(self.state.machine.draw, path, resume)
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
        if data.get("state") not in ("up", "down"):
            return error(400, 'give {"state": "up"} or {"state": "down"}')
        moved, answer = await self._act(self.state.machine.pen, data["state"])
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
                every = EVENT_EVERY_S if st.get("busy") else IDLE_EVERY_S
                if key != last or now - sent >= every:
                    yield f"data: {json.dumps(st)}\n\n"
                    last, sent = key, now
                await asyncio.sleep(0.25)

        return StreamingResponse(stream(), media_type="text/event-stream",
                                 headers={"Cache-Control": "no-store", "X-Accel-Buffering": "no"})
