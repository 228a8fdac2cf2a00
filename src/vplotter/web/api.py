"""The JSON API under /api (the page uses nothing else): status, files, draw, stop, pen, jog,
and server-sent events. What touches the plotter goes through the Machine of
commands/serve.py; a draw runs as `draw FILE --detach` does, in its own process."""

from __future__ import annotations

import asyncio
import json
import math
import re
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

    async def get_status(request):
        from starlette.responses import JSONResponse

        return JSONResponse(await asyncio.to_thread(state.status))

    async def list_files(request):
        from starlette.responses import JSONResponse

        return JSONResponse(state.folder.listing())

    async def upload(request):
        from starlette.formparsers import MultiPartException, MultiPartParser
        from starlette.responses import JSONResponse

        declared = request.headers.get("content-length")
        if declared is not None and declared.isdigit() and int(declared) > MAX_BYTES + 65536:
            return error(413, f"the file is larger than {MAX_BYTES >> 20} MB")
        if not request.headers.get("content-type", "").startswith("multipart/form-data"):
            return error(400, "send the file as multipart/form-data in the field `file`")

        async def limited():
            n = 0
            async for chunk in request.stream():
                n += len(chunk)
                if n > MAX_BYTES + 65536:
                    raise TooBig
                yield chunk

        try:
            form = await MultiPartParser(request.headers, limited(), max_files=1,
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
            async with state.working:
                tmp = state.folder.incoming(up.filename)
                try:
                    await up.seek(0)
                    with open(tmp, "wb") as out:
                        while block := await up.read(1 << 20):
                            out.write(block)
                    estimate_s = await asyncio.to_thread(state.machine.estimate, str(tmp))
                except Exception as e:
                    state.folder.discard(tmp)
                    from vplotter.errors import VplotterError

                    if isinstance(e, VplotterError):
                        text = str(e).replace(str(tmp.parent) + "/", "")
                        return error(400, first_line(text))
                    raise
                name = state.folder.keep(tmp, estimate_s)
        except FileError as e:
            return error(e.status, str(e))
        finally:
            await form.close()
        return JSONResponse({"name": name, "estimate_s": round(estimate_s, 1)}, status_code=201)

    async def delete_file(request):
        from starlette.responses import JSONResponse

        try:
            state.folder.delete(request.path_params["name"])
        except FileError as e:
            return error(e.status, str(e))
        return JSONResponse({"deleted": request.path_params["name"]})

    async def preview(request):
        from starlette.responses import Response

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

    async def body_json(request) -> dict:
        try:
            data = json.loads(await request.body() or b"{}")
        except ValueError:
            raise FileError(400, "the body must be a JSON object") from None
        if not isinstance(data, dict):
            raise FileError(400, "the body must be a JSON object")
        return data

    def busy():
        holder = state.machine.holder()
        return None if holder is None else error(409, state.machine.busy_line(holder))

    def answer(code: int, out: str, err: str, ok: dict):
        from starlette.responses import JSONResponse

        state.forget_status()
        if code == 0:
            status = ok.pop("_status", 200)
            lines = [ln.strip() for ln in out.splitlines() if ln.strip()]
            return JSONResponse({**ok, "message": lines[0] if lines else ""},
                                status_code=status)
        status = {2: 400, 3: 409}.get(code, 500)
        return error(status, first_line(err) if status != 409 else err.strip().splitlines()[0])

    async def draw(request):
        try:
            data = await body_json(request)
            resume = bool(data.get("resume", False))
            if data.get("file") is None and resume:
                stored = (await asyncio.to_thread(state.status)).get("resume") or {}
                if not stored.get("file"):
                    return error(400, "nothing to resume: no interrupted draw is stored")
                path = stored["file"]
            else:
                path = str(state.folder.file(str(data.get("file", ""))))
        except FileError as e:
            return error(e.status, str(e))
        async with state.acting:
            if (refusal := busy()) is not None:
                return refusal
            code, out, err = await asyncio.to_thread(state.machine.draw, path, resume)
        m = re.search(r"background: pid (\d+)", out)
        return answer(code, out, err, {"pid": int(m.group(1)) if m else None, "_status": 202})

    async def stop(request):
        async with state.acting:
            code, out, err = await asyncio.to_thread(state.machine.stop)
        return answer(code, out, err, {"stopped": "stopped pid" in out})

    async def go_on(request):
        async with state.acting:
            code, out, err = await asyncio.to_thread(state.machine.continue_)
        if code == 2:                       # nothing waits: the state says otherwise
            return error(409, first_line(err).removeprefix("vplotter: "))
        return answer(code, out, err, {"continued": True})

    async def pen(request):
        try:
            data = await body_json(request)
        except FileError as e:
            return error(e.status, str(e))
        if data.get("state") not in ("up", "down"):
            return error(400, 'give {"state": "up"} or {"state": "down"}')
        async with state.acting:
            if (refusal := busy()) is not None:
                return refusal
            code, out, err = await asyncio.to_thread(state.machine.pen, data["state"])
        return answer(code, out, err, {"pen": data["state"]})

    async def jog(request):
        try:
            data = await body_json(request)
            dx, dy = (float(data.get(k, 0.0)) for k in ("dx", "dy"))
        except FileError as e:
            return error(e.status, str(e))
        except (TypeError, ValueError):
            return error(400, 'give {"dx": MM, "dy": MM}')
        if not all(math.isfinite(v) and abs(v) <= 1000 for v in (dx, dy)) or dx == dy == 0:
            return error(400, "dx and dy must be numbers of mm up to 1000, not both 0")
        async with state.acting:
            if (refusal := busy()) is not None:
                return refusal
            code, out, err = await asyncio.to_thread(state.machine.jog, dx, dy)
        return answer(code, out, err, {"dx": dx, "dy": dy})

    async def events(request):
        from starlette.responses import StreamingResponse

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

    return [
        Route("/api/status", get_status, methods=["GET"]),
        Route("/api/files", list_files, methods=["GET"]),
        Route("/api/files", upload, methods=["POST"]),
        Route("/api/files/{name}", delete_file, methods=["DELETE"]),
        Route("/api/files/{name}/preview.png", preview, methods=["GET"]),
        Route("/api/draw", draw, methods=["POST"]),
        Route("/api/stop", stop, methods=["POST"]),
        Route("/api/continue", go_on, methods=["POST"]),
        Route("/api/pen", pen, methods=["POST"]),
        Route("/api/jog", jog, methods=["POST"]),
        Route("/api/events", events, methods=["GET"]),
    ]
