"""The handlers of the uploaded drawings: list, upload, options, preview, delete.

Each stored file keeps beside it (web/files.Folder) the file options the page chose for it
(commands/page_options: `draw`'s own: width, fit, style, max_time, fill), the estimate they give,
and what a photo's budget said (notes) and advises (advice). Estimate, preview and draw all
take the file with those options, so what the page shows is what is drawn.
"""

from __future__ import annotations

import asyncio
import json

from vplotter.web.answers import Acting, error, first_line
from vplotter.web.files import MAX_BYTES, FileError


class TooBig(Exception):
    pass


async def _limited(request):
    """The request's body, refused (TooBig) past the upload limit while it streams."""
    n = 0
    async for chunk in request.stream():
        n += len(chunk)
        if n > MAX_BYTES + 65536:
            raise TooBig
        yield chunk


class DrawingHandlers(Acting):
    def entry(self, item: dict) -> dict:
        """A listing's item with the file's kind, the options it takes, and what is kept beside
        it: {"name", "size", "estimate_s", "kind", "takes", "options", "notes", "advice"}."""
        folder = self.state.folder
        kind, takes = self.state.machine.kind(str(folder.path / item["name"]))
        return {**item, "kind": kind, "takes": takes, **folder.extras(item["name"])}

    def options(self, name: str) -> dict:
        """The options kept for the stored file `name`."""
        from vplotter.errors import VplotterError

        path = str(self.state.folder.path / name)
        try:
            return self.state.machine.options(path, self.state.folder.extras(name)["options"])
        except VplotterError:            # a meta file edited by hand: none
            return {}

    async def list_files(self, request):
        from starlette.responses import JSONResponse

        items = self.state.folder.listing()
        return JSONResponse(await asyncio.to_thread(lambda: [self.entry(i) for i in items]))

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
            try:
                wanted = json.loads(form.get("options") or "{}")
            except (TypeError, ValueError):
                return error(400, "the field `options` must be a JSON object")
            async with self.state.working:
                kept = await self._keep(up, wanted)
        except FileError as e:
            return error(e.status, str(e))
        finally:
            await form.close()
        if not isinstance(kept, str):
            return kept
        item = next(i for i in self.state.folder.listing() if i["name"] == kept)
        return JSONResponse(await asyncio.to_thread(self.entry, item), status_code=201)

    async def _keep(self, up, wanted):
        """Write the upload inside the folder, estimate it with the options `wanted` that its
        kind takes (the others are left out), keep it: its name, or the 400 answer of a file
        or options that do not validate (nothing is kept)."""
        from vplotter.errors import VplotterError

        folder, machine = self.state.folder, self.state.machine
        tmp = folder.incoming(up.filename)
        try:
            await up.seek(0)
            with open(tmp, "wb") as out:
                while block := await up.read(1 << 20):
                    out.write(block)
            chosen = machine.options(str(tmp), wanted, taken_only=True)
            got = await asyncio.to_thread(machine.estimate, str(tmp), chosen)
        except Exception as e:
            folder.discard(tmp)
            if isinstance(e, VplotterError):
                return error(400, first_line(str(e).replace(str(tmp.parent) + "/", "")))
            raise
        return folder.keep(tmp, got.time_s, _extras(chosen, got))

    async def set_options(self, request):
        """POST /api/files/NAME/options: estimate the file with these options and keep them
        (400 with the command line's error, nothing changed, when they do not validate)."""
        from starlette.responses import JSONResponse

        from vplotter.errors import VplotterError
        from vplotter.web.answers import body_json

        folder, machine = self.state.folder, self.state.machine
        try:
            path = folder.file(request.path_params["name"])
            data = await body_json(request)
            chosen = machine.options(str(path), data)
            async with self.state.working:
                got = await asyncio.to_thread(machine.estimate, str(path), chosen)
                folder.note(path.name, got.time_s, _extras(chosen, got))
        except FileError as e:
            return error(e.status, str(e))
        except VplotterError as e:
            return error(400, first_line(str(e).replace(str(folder.path) + "/", "")))
        item = next(i for i in folder.listing() if i["name"] == path.name)
        return JSONResponse(await asyncio.to_thread(self.entry, item))

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
                code, err = await asyncio.to_thread(state.machine.preview, str(path), str(png),
                                                    900, self.options(path.name))
                if code != 0 or not png.exists():
                    return error(400 if code == 2 else 500, first_line(err))
        return Response(png.read_bytes(), media_type="image/png",
                        headers={"Cache-Control": "no-cache"})


def _extras(chosen: dict, got) -> dict:
    return {"options": chosen, "notes": list(got.notes), "advice": list(got.advice)}
