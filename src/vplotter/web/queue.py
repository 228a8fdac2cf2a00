"""The handlers of the job queue and the history: GET/POST /api/queue, DELETE /api/queue/ID,
POST /api/queue/ID/move, POST /api/queue/run, GET /api/history; and GET /api/now/paths, the
running draw's planned path (the page shows the part drawn grow on it).

A job is added from the upload folder (its name there, with the options kept for it unless
the request gives its own), validated as `vplotter queue add` validates it (400 with the
command line's error, nothing added); the queue runs as `vplotter queue run --detach`, in its
own process. The answers are the values of `vplotter queue --json` and `history --json`."""

from __future__ import annotations

import asyncio

from vplotter.web.answers import Acting, body_json, error, first_line
from vplotter.web.files import FileError

MAX_COPIES = 1000


def _whole(value, lo: int, hi: int, what: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or not lo <= value <= hi:
        raise FileError(400, f"{what} must be a whole number from {lo} to {hi}")
    return value


class QueueHandlers(Acting):
    async def get_queue(self, request):
        from starlette.responses import JSONResponse

        return JSONResponse(await asyncio.to_thread(self.state.machine.queue))

    async def add_job(self, request):
        """{"file": NAME, "copies": N, "options": {...}}: 201 with the job and the message."""
        import dataclasses

        from starlette.responses import JSONResponse

        from vplotter.errors import VplotterError

        folder, machine = self.state.folder, self.state.machine
        try:
            data = await body_json(request)
            path = folder.file(str(data.get("file", "")))
            copies = _whole(data.get("copies", 1), 1, MAX_COPIES, "copies")
            options = data.get("options")
            options = self.options(path.name) if options is None else \
                machine.options(str(path), options)
            async with self.state.working:
                added = await asyncio.to_thread(machine.queue_add, str(path), copies, options)
        except FileError as e:
            return error(e.status, str(e))
        except VplotterError as e:
            if getattr(e, "exit_code", 2) == 2:
                line = first_line(machine.error_line(e))
                return error(400, line.replace(str(folder.path) + "/", ""))
            return self._failed(e)
        return JSONResponse(dataclasses.asdict(added), status_code=201)

    async def remove_job(self, request):
        return await self._change(self.state.machine.queue_remove, request.path_params["id"])

    async def move_job(self, request):
        try:
            data = await body_json(request)
            pos = _whole(data.get("position"), 1, 1_000_000, "position")
        except FileError as e:
            return error(e.status, str(e))
        return await self._change(self.state.machine.queue_move, request.path_params["id"], pos)

    async def _change(self, do, job_id: str, *more):
        from starlette.responses import JSONResponse

        from vplotter.errors import VplotterError

        if not job_id.isdigit() or len(job_id) > 9:
            return error(404, f"no job {job_id[:20]} in the queue")
        try:
            return JSONResponse(await asyncio.to_thread(do, int(job_id), *more))
        except VplotterError as e:
            line = first_line(self.state.machine.error_line(e)).removeprefix("vplotter: ")
            return error(404 if "no job" in line else 400, line.removeprefix("error: "))

    async def run_queue(self, request):
        """Draw the queue in the background (202), as `vplotter queue run --detach`."""
        if (refusal := self._busy() or await self._need_position()) is not None:
            return refusal
        started, answer = await self._act(self.state.machine.queue_run)
        return answer or self._done(started, {"pid": started.pid}, 202)

    async def get_history(self, request):
        from starlette.responses import JSONResponse

        return JSONResponse(await asyncio.to_thread(self.state.machine.history))

    async def now_paths(self, request):
        """The running draw's planned path, once per drawing (the page draws the part done
        from the events' `line`); 404 when nothing is drawn."""
        from starlette.responses import JSONResponse

        async with self.state.working:
            got = await asyncio.to_thread(self.state.machine.now_paths)
        if got is None:
            return error(404, "nothing is being drawn")
        return JSONResponse(got, headers={"Cache-Control": "no-store"})
