"""The upload folder: safe names, size and count limits, the estimate kept beside each file.

Every name that comes from outside (an upload's filename, NAME in /api/files/NAME) goes
through safe_name(): its last path part (after / and \\), NUL and other control characters
gone, anything but ASCII letters, digits, '.', '-' and '_' replaced by '_', no leading dots or
dashes (no hidden files, no option-like names), at most MAX_NAME characters. A file is
written only as .incoming-*/NAME inside the folder and renamed into place after it has been
validated; what fails leaves nothing.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import tempfile
from pathlib import Path

MAX_BYTES = 50 * 1024 * 1024      # one upload
MAX_FILES = 200                   # files kept in the upload folder
MAX_NAME = 100
META = ".meta"                    # NAME.json: {"estimate_s", "size", "mtime_ns"} and EXTRAS
EXTRAS = {"options": {}, "notes": [], "advice": []}   # what the page chose, what it was told


class FileError(Exception):
    """An error for the person: HTTP status and one line."""

    def __init__(self, status: int, message: str):
        super().__init__(message)
        self.status = status


def safe_name(raw: str) -> str:
    """A base name that cannot leave the folder, or FileError 400."""
    name = str(raw).replace("\\", "/").rsplit("/", 1)[-1]
    name = "".join(c for c in name if c.isprintable() and c != "\x00")
    name = re.sub(r"[^A-Za-z0-9._-]+", "_", name).lstrip(".-_")
    if len(name) > MAX_NAME:
        stem, dot, ext = name.rpartition(".")
        ext = ext[:10] if dot else ""
        name = (stem if dot else name)[:MAX_NAME - len(ext) - 1].rstrip(".") + (dot + ext)
    if not name or name in (".", ".."):
        raise FileError(400, f"not a usable file name: {str(raw)[:60]!r}")
    return name


class Folder:
    def __init__(self, path: Path):
        self.path = Path(path).resolve()
        self.path.mkdir(parents=True, exist_ok=True)
        (self.path / META).mkdir(exist_ok=True)
        for e in os.scandir(self.path):          # left over from a server that was killed
            if e.name.startswith(".incoming-") and e.is_dir():
                shutil.rmtree(e.path, ignore_errors=True)

    def file(self, raw: str) -> Path:
        """The stored file named raw (after safe_name), or FileError 404."""
        try:
            name = safe_name(raw)
        except FileError:
            name = ""
        p = self.path / name
        if not name or name != raw or not p.is_file() or p.parent != self.path:
            raise FileError(404, f"no such file: {str(raw)[:60]}")
        return p

    def names(self) -> list[str]:
        return sorted(e.name for e in os.scandir(self.path)
                      if e.is_file() and not e.name.startswith("."))

    def listing(self) -> list[dict]:
        out = []
        for name in self.names():
            p = self.path / name
            st = p.stat()
            meta = self._meta(name)
            fresh = meta.get("size") == st.st_size and meta.get("mtime_ns") == st.st_mtime_ns
            out.append({"name": name, "size": st.st_size,
                        "estimate_s": meta.get("estimate_s") if fresh else None})
        return out

    def _meta(self, name: str) -> dict:
        try:
            with open(self.path / META / f"{name}.json", encoding="utf-8") as f:
                data = json.load(f)
            return data if isinstance(data, dict) else {}
        except (OSError, ValueError):
            return {}

    def incoming(self, raw_name: str) -> Path:
        """A fresh path .incoming-XXXX/NAME inside the folder to write an upload to (the
        caller validates it, then keep() or discard())."""
        name = safe_name(raw_name)
        names = self.names()
        if name not in names and len(names) >= MAX_FILES:
            raise FileError(409, f"the upload folder holds {MAX_FILES} files: delete some first")
        return Path(tempfile.mkdtemp(prefix=".incoming-", dir=self.path)) / name

    def extras(self, name: str) -> dict:
        """The options, notes and advice kept with the stored file `name` (EXTRAS when none
        are kept, or the file changed since)."""
        p = self.path / name
        meta = self._meta(name)
        try:
            st = p.stat()
        except OSError:
            return dict(EXTRAS)
        if meta.get("size") != st.st_size or meta.get("mtime_ns") != st.st_mtime_ns:
            return dict(EXTRAS)
        return {k: meta.get(k, v) for k, v in EXTRAS.items()}

    def keep(self, tmp: Path, estimate_s: float, extras: dict | None = None) -> str:
        name = tmp.name
        dest = self.path / name
        os.replace(tmp, dest)
        shutil.rmtree(tmp.parent, ignore_errors=True)
        self.note(name, estimate_s, extras)
        return name

    def note(self, name: str, estimate_s: float, extras: dict | None = None) -> None:
        """Keep the estimate (and EXTRAS: the options it was made with, its notes) beside the
        stored file `name`; its preview is made again when next asked for."""
        st = (self.path / name).stat()
        meta = {"estimate_s": round(float(estimate_s), 1), "size": st.st_size,
                "mtime_ns": st.st_mtime_ns,
                **{k: (extras or {}).get(k, v) for k, v in EXTRAS.items()}}
        tmp = self.path / META / f".{name}.json.tmp"
        with open(tmp, "w", encoding="utf-8") as f:
            json.dump(meta, f)
        os.replace(tmp, self.path / META / f"{name}.json")
        self._drop_preview(name)

    @staticmethod
    def discard(tmp: Path) -> None:
        shutil.rmtree(tmp.parent, ignore_errors=True)

    def delete(self, raw: str) -> None:
        p = self.file(raw)
        p.unlink()
        (self.path / META / f"{p.name}.json").unlink(missing_ok=True)
        self._drop_preview(p.name)

    def preview_path(self, name: str) -> Path:
        return self.path / META / f"{name}.png"

    def _drop_preview(self, name: str) -> None:
        self.preview_path(name).unlink(missing_ok=True)
