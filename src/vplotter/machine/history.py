"""The plots drawn on this machine: $XDG_STATE_HOME/vplotter/history.jsonl, append-only JSON
lines, each one written whole, flushed and fsync'd before the plot goes on.

Every draw that moves the machine writes two records with the same "id":

    {"event": "started", "id", "pid", "file", "path", "start", "estimate_s", "drawn_mm",
     "pens", "copy"}
    {"event": "ended", "id", "end", "actual_s", "drawn_mm", "result", "error"}

start and end are epoch seconds; estimate_s the plot time the validation planned, actual_s the
time from the start to the end without the time spent waiting at pauses (a pen change);
drawn_mm the pen-down length (planned at the start, what was played at the end: the part of the
plan's time played, times its drawn length); pens the pens the drawing changes between (empty:
one pen); copy "2 of 5" for a copy of a queue job, else null; result "done", "stopped" (a
signal: `vplotter stop`, Ctrl+C; resumable) or "failed" (error: the one line it ended with).

A started record without its end whose process is no longer the one driving the plotter was
cut short by a power cut or a crash: it reads as "interrupted (power cut or crash)". A torn last
line (the power went while it was written) is skipped.
"""

from __future__ import annotations

import json
import os
import time
from contextlib import contextmanager
from pathlib import Path

from vplotter.config import state_dir

clock = time.time          # (tests put a simulated clock here)
INTERRUPTED = "interrupted (power cut or crash)"


def history_path() -> Path:
    return state_dir() / "history.jsonl"


def append(rec: dict) -> None:
    """One record, whole, on disk before this returns."""
    path = history_path()
    path.parent.mkdir(parents=True, exist_ok=True)
    data = (json.dumps(rec) + "\n").encode()
    fd = os.open(path, os.O_RDWR | os.O_APPEND | os.O_CREAT, 0o644)
    try:
        size = os.fstat(fd).st_size
        if size and os.pread(fd, 1, size - 1) != b"\n":      # a torn last line: end it
            data = b"\n" + data
        os.write(fd, data)
        os.fsync(fd)
    finally:
        os.close(fd)


class Plot:
    """The history of one draw: started() once it is validated, waiting(on) around pauses,
    ended() once; nothing is written before started()."""

    def __init__(self, path: str, name: str | None = None, copy: str | None = None):
        self.path, self.name, self.copy = path, name or os.path.basename(path), copy
        self.id: str | None = None
        self.t0 = 0.0
        self.estimate_s, self.drawn_mm = 0.0, 0.0
        self.waited, self._since = 0.0, None

    def started(self, estimate_s: float, drawn_mm: float, pens) -> None:
        self.t0 = clock()
        self.id = f"{os.getpid()}-{self.t0:.6f}"
        self.estimate_s, self.drawn_mm = float(estimate_s), float(drawn_mm)
        append({"event": "started", "id": self.id, "pid": os.getpid(), "file": self.name,
                "path": self.path, "start": self.t0, "estimate_s": round(self.estimate_s, 3),
                "drawn_mm": round(self.drawn_mm, 1), "pens": list(pens), "copy": self.copy})

    def started_with(self, summary) -> None:
        """started() with a validation's pipeline.Summary."""
        self.started(summary.time_s, summary.drawn_mm, [p[0] for p in summary.pens])

    def waiting(self, on: bool) -> None:
        """A pause began (on) or ended: its time is not plot time."""
        now = clock()
        if on and self._since is None:
            self._since = now
        elif not on and self._since is not None:
            self.waited += now - self._since
            self._since = None

    def hook(self, then=None):
        """A live.Publisher on_state hook that notes the waits, then calls `then`."""
        def on_state(state: str, info: dict) -> None:
            if state in ("waiting", "drawing"):
                self.waiting(state == "waiting")
            if then is not None:
                then(state, info)
        return on_state

    def ended(self, result: str, done_s: float | None = None, error: str | None = None) -> None:
        """result: done, stopped or failed; done_s: the plan's time played (None: all)."""
        if self.id is None:
            return
        self.waiting(False)
        end = clock()
        frac = 1.0 if done_s is None or self.estimate_s <= 0 else \
            min(1.0, max(0.0, done_s / self.estimate_s))
        append({"event": "ended", "id": self.id, "end": end,
                "actual_s": round(max(0.0, end - self.t0 - self.waited), 3),
                "drawn_mm": round(self.drawn_mm * frac, 1), "result": result, "error": error})
        self.id = None


def plot_for(args) -> "Plot | None":
    """The history of `draw`'s args: none for a dry run, nor for the command that hands a
    draw to the background (--detach: the background process keeps it). A queue job gives its
    name and copy (args.job_name, args.job_copy), or its Plot (args.plot)."""
    if getattr(args, "dry_run", False) or getattr(args, "detach", False):
        return None
    return getattr(args, "plot", None) or Plot(os.path.abspath(args.file),
                                               getattr(args, "job_name", None),
                                               getattr(args, "job_copy", None))


@contextmanager
def kept(plot: "Plot | None", session, line):
    """The end of a session's draw in the history: done, stopped (a signal) or failed with
    line(error), the one line the command ends with."""
    from vplotter.errors import Interrupted

    try:
        yield
    except Interrupted:
        if plot is not None:
            plot.ended("stopped", session.t_us / 1e6)
        raise
    except BaseException as e:
        if plot is not None:
            plot.ended("failed", session.t_us / 1e6, line(e))
        raise
    if plot is not None:
        plot.ended("done")


def failed(path: str, name: str, error: str, copy: str | None = None) -> None:
    """A draw that ended before it started moving (a queue job whose file no longer
    validates): one started and one ended record, at once."""
    p = Plot(path, name, copy)
    p.started(0.0, 0.0, [])
    p.ended("failed", 0.0, error)


def read(path: Path | None = None, running_pid: int | None = None) -> list[dict]:
    """The plots, oldest first: {"id", "file", "path", "start", "end", "estimate_s",
    "actual_s", "drawn_m", "pens", "copy", "result", "error"}. A plot without its end is
    "running" while its process drives the plotter (running_pid; None: asked of the lock),
    else INTERRUPTED."""
    p = path or history_path()
    try:
        lines = p.read_bytes().decode("utf-8", "replace").splitlines()
    except FileNotFoundError:
        return []
    plots: dict[str, dict] = {}
    for line in lines:
        try:
            rec = json.loads(line)
            if not isinstance(rec, dict) or not isinstance(rec.get("id"), str):
                continue
            if rec.get("event") == "started":
                plots[rec["id"]] = _plot(rec)
            elif rec.get("event") == "ended" and rec["id"] in plots:
                plots[rec["id"]].update(
                    end=float(rec["end"]), actual_s=float(rec["actual_s"]),
                    drawn_m=round(float(rec.get("drawn_mm", 0.0)) / 1000, 3),
                    result=str(rec["result"]), error=rec.get("error"))
        except (ValueError, KeyError, TypeError):
            continue                # a torn line: the power went while it was written
    if running_pid is None:
        from vplotter.machine import lock

        running_pid = (lock.holder() or {}).get("pid")
    for plot in plots.values():
        if plot["result"] is None:
            plot["result"] = "running" if plot.pop("pid") == running_pid else INTERRUPTED
        else:
            plot.pop("pid")
    return list(plots.values())


def _plot(rec: dict) -> dict:
    return {"id": rec["id"], "pid": int(rec["pid"]), "file": str(rec["file"]),
            "path": str(rec.get("path", "")), "start": float(rec["start"]), "end": None,
            "estimate_s": float(rec["estimate_s"]), "actual_s": None,
            "drawn_m": round(float(rec.get("drawn_mm", 0.0)) / 1000, 3),
            "pens": [str(p) for p in rec.get("pens") or []], "copy": rec.get("copy"),
            "result": None, "error": None}
