"""The job queue: $XDG_STATE_HOME/vplotter/queue/queue.json, and a copy of each job's file in
queue/ID/NAME (made when the job is added: a later edit, move or removal of the original does
not change the job).

    {"version": 1, "next_id": 4, "jobs": [{"id", "name", "file", "source", "options",
     "copies", "done", "estimate_s", "added", "stopped"}]}

name is the file's own name (poster.svg), file the copy's path, source where it was copied
from, options the file options' command-line words it is drawn with (`--width=300`), copies
how many to draw, done how many are drawn, estimate_s the plot time of one copy when it was
added, stopped: its copy was stopped part-way (`queue run` resumes it).

Every change is a read-modify-write under an exclusive flock of queue/lock, and the file is
replaced atomically (temporary file, fsync, rename, fsync of the folder): a power cut leaves
the queue as it was before the change or after it, never half written.
"""

from __future__ import annotations

import fcntl
import json
import os
import shutil
import time
from contextlib import contextmanager
from pathlib import Path

from vplotter.config import state_dir
from vplotter.errors import ConfigError, StateError
from vplotter.machine.state import atomic_write

VERSION = 1
MAX_COPIES = 1000


def queue_dir() -> Path:
    return state_dir() / "queue"


def queue_path() -> Path:
    return queue_dir() / "queue.json"


def _empty() -> dict:
    return {"version": VERSION, "next_id": 1, "jobs": []}


def load() -> dict:
    """The queue (empty when none is stored); StateError when it cannot be read."""
    p = queue_path()
    try:
        data = json.loads(p.read_text(encoding="utf-8"))
    except FileNotFoundError:
        return _empty()
    except OSError as e:
        raise StateError(f"{p}: error: cannot read the queue: {e.strerror}") from None
    except ValueError as e:
        raise StateError(f"{p}: error: the queue is corrupt ({e}); `vplotter queue clear` "
                         f"empties it") from None
    if not isinstance(data, dict) or data.get("version") != VERSION \
            or not isinstance(data.get("jobs"), list):
        raise StateError(f"{p}: error: the queue is corrupt (unknown version); "
                         f"`vplotter queue clear` empties it")
    return data


def jobs() -> list[dict]:
    return load()["jobs"]


@contextmanager
def changing(tolerate_corrupt: bool = False):
    """The queue to change, written back (atomically) when the block ends without an error;
    one change at a time (flock)."""
    d = queue_dir()
    d.mkdir(parents=True, exist_ok=True)
    fd = os.open(d / "lock", os.O_RDWR | os.O_CREAT | os.O_CLOEXEC, 0o644)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        try:
            data = load()
        except StateError:
            if not tolerate_corrupt:
                raise
            data = _empty()
        yield data
        atomic_write(queue_path(), json.dumps(data, indent=1) + "\n")
    finally:
        os.close(fd)


def find(data: dict, job_id: int) -> dict:
    for job in data["jobs"]:
        if job["id"] == job_id:
            return job
    raise ConfigError(f"error: no job {job_id} in the queue (`vplotter queue` lists them)")


def add(source: str, options: list[str], copies: int, estimate_s: float) -> dict:
    """Copy `source` into the queue's folder and put it last: the job."""
    if not 1 <= copies <= MAX_COPIES:
        raise ConfigError(f"error: --copies must be 1 to {MAX_COPIES} (got {copies})")
    with changing() as data:
        job_id = int(data["next_id"])
        folder = queue_dir() / str(job_id)
        folder.mkdir(parents=True, exist_ok=True)
        name = os.path.basename(source)
        copy = folder / name
        shutil.copyfile(source, copy)
        with open(copy, "rb") as f:
            os.fsync(f.fileno())
        job = {"id": job_id, "name": name, "file": str(copy), "source": os.path.abspath(source),
               "options": [str(w) for w in options], "copies": int(copies), "done": 0,
               "estimate_s": round(float(estimate_s), 3), "added": time.time(),
               "stopped": False}
        data["jobs"].append(job)
        data["next_id"] = job_id + 1
    return job


def move(job_id: int, position: int) -> list[dict]:
    """Put job `job_id` at `position` (1: first; past the end: last)."""
    with changing() as data:
        job = find(data, job_id)
        if position < 1:
            raise ConfigError(f"error: the position must be 1 or more (got {position})")
        data["jobs"].remove(job)
        data["jobs"].insert(min(position, len(data["jobs"]) + 1) - 1, job)
    return data["jobs"]


def remove(job_id: int) -> dict:
    with changing() as data:
        job = find(data, job_id)
        data["jobs"].remove(job)
    _forget(job)
    return job


def clear() -> int:
    """Empty the queue (also a corrupt one): how many jobs it had."""
    with changing(tolerate_corrupt=True) as data:
        gone = list(data["jobs"])
        data["jobs"] = []
    for job in gone:
        _forget(job)
    return len(gone)


def _forget(job: dict) -> None:
    shutil.rmtree(queue_dir() / str(int(job["id"])), ignore_errors=True)


def copy_done(job_id: int) -> dict | None:
    """One more copy of job_id is drawn: the job (None once all its copies are drawn and it
    has left the queue)."""
    with changing() as data:
        job = next((j for j in data["jobs"] if j["id"] == job_id), None)
        if job is None:                  # taken out of the queue while it was drawn
            return None
        job["done"] = int(job["done"]) + 1
        job["stopped"] = False
        left = job["done"] < int(job["copies"])
        if not left:
            data["jobs"].remove(job)
    if not left:
        _forget(job)
    return job if left else None


def mark_stopped(job_id: int, stopped: bool = True) -> None:
    with changing() as data:
        for job in data["jobs"]:
            if job["id"] == job_id:
                job["stopped"] = stopped


def left_s(job: dict) -> float:
    """The plot time of the copies still to draw."""
    return float(job["estimate_s"]) * max(0, int(job["copies"]) - int(job["done"]))
