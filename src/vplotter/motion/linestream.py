"""Planned blocks -> G-code lines for a controller that plans its own motion (grbl & co).

`LineScheduler` takes the step scheduler's place in `pipeline.stream`: the pipeline still
validates, orders, resumes and plans (so the clock, the plot time and the progress are the same
as on the GPIO path), but what comes out is `Lines` to stream, not step rows.

Stream coordinates ([serial] axes):
- "motors": X and Y are the kinematics' motor coordinates (the left and right cord, mm). Each
  straight piece is cut by `motorcut` so that the straight motor-space line maps back to the
  wall within the tolerance; the feed F (mm/min in motor space) of each sub-piece keeps the pen
  at or below its speed cap (times feed_scale).
- "xy": X and Y are the G-code coordinates of the pieces; the firmware does the kinematics.

The stream starts with `G21G90G94` and `G92` (the controller's work position is set to where
the pen is, in stream coordinates; `$` settings are never touched), pen changes are the
configured command followed by `G4 P<settle_s>`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vplotter.motion import motorcut
from vplotter.motion.planner import Block
from vplotter.motion.schedule import Scheduler

CHORD_SHARE = 0.5       # of tolerance_mm for the chords of arcs (as on the GPIO path: 0.75)
CUT_SHARE = 0.45        # for the motor-space cut; the rest covers rounding to DECIMALS
DECIMALS = 3
FEED_MARGIN = 0.99
FEED_GRID = 1.01        # feeds are sent on a geometric grid of 1 % steps


@dataclass
class Lines:
    """G-code lines to stream, with what each line leaves behind (one row per line)."""

    text: list[str]
    line: np.ndarray        # (n,) G-code line of the file
    motion: np.ndarray      # (n,) bool: a G1 move
    q: np.ndarray           # (n, 2) stream coordinates after the line
    xy: np.ndarray          # (n, 2) pen in G-code coordinates after the line
    down: np.ndarray        # (n,) bool: pen down after the line
    t_us: np.ndarray        # (n,) planned time at the end of the line

    def __len__(self) -> int:
        return len(self.text)


def fmt(v: float) -> str:
    """A coordinate with DECIMALS places, no trailing zeros, never -0."""
    s = f"{v:.{DECIMALS}f}".rstrip("0").rstrip(".")
    return "0" if s in ("-0", "") else s


class LineScheduler(Scheduler):
    chord_share = CHORD_SHARE

    one_coil_rest = False     # the controller drives the motors, not coil phases

    def __init__(self, cfg, kin, counts, ref_mm):
        super().__init__(cfg, kin, counts, ref_mm)
        self.ser = cfg.serial
        self.motors = self.ser.axes == "motors"
        self.tol_cut = cfg.motion.tolerance_mm * CUT_SHARE
        cords = self.ref + self.counts / self.spu
        self.xy_m = kin.forward(cords[None, :])[0]          # machine frame
        self.q = self._q(self.xy_m[None, :])[0]
        self.feed = None
        self.lines_total = 0

    def _q(self, xy_m: np.ndarray) -> np.ndarray:
        q = self.kin.inverse(xy_m) if self.motors else self.kin.to_gcode(xy_m)
        return np.round(q, DECIMALS)

    def _plain(self, text: list[str], line: int) -> Lines:
        n = len(text)
        self.lines_total += n
        gxy = self.kin.to_gcode(self.xy_m)
        return Lines(list(text), np.full(n, line, dtype=np.int64), np.zeros(n, dtype=bool),
                     np.repeat(self.q[None, :], n, axis=0), np.repeat(gxy[None, :], n, axis=0),
                     np.full(n, self.pen_down), np.full(n, self.t_us, dtype=np.int64))

    # -- the Scheduler interface, with lines instead of rows
    def start(self, pen_down: bool | None = None) -> Lines:
        head = ["G21G90G94", f"G92X{fmt(self.q[0])}Y{fmt(self.q[1])}"]
        if pen_down is None:
            super().start(None)
            self.pen_down = False
            return self._plain(head + [self.ser.pen_up, self._settle()], 0)
        super().start(pen_down)
        return self._plain(head, 0)

    def _settle(self) -> str:
        return f"G4P{self.cfg.pen.settle_s:g}"

    def pen(self, down: bool, line: int = 0, emit: bool = True) -> Lines | None:
        changed = down != self.pen_down
        super().pen(down, line, emit=False)
        if not changed:
            return None
        out = self._plain([self.ser.pen_down if down else self.ser.pen_up, self._settle()], line)
        return out if emit else None                  # counted either way (lines_total)

    def dwell(self, seconds: float, line: int = 0) -> Lines | None:
        super().dwell(seconds, line)
        return self._plain([f"G4P{seconds:.3f}".rstrip("0").rstrip(".")], line)

    def finish(self, lift: bool = True) -> Lines | None:
        return self.pen(False, self.line) if lift else None

    def motion(self, block: Block, emit: bool = True) -> Lines | None:
        t0 = self.t_us + (0 if self.energized else self.hold_us)
        super().motion(block, emit=False)
        verts = block.verts
        if self.motors:
            pts, piece = motorcut.cut(self.kin, verts, self.tol_cut)
        else:
            pts, piece = verts[1:], np.arange(len(block.d))
        prev = np.vstack((verts[:1], pts[:-1]))
        feed = block.cap[piece] * 60.0 * self.ser.feed_scale
        if self.motors:
            feed = feed * motorcut.cord_speed_ratio(self.kin, prev, pts) * FEED_MARGIN
            # down to a 1 % grid, so that F changes only every few lines (fewer bytes to send)
            feed = FEED_GRID ** np.floor(np.log(feed) / np.log(FEED_GRID) + 1e-9)
        feed = np.floor(feed * 10.0) / 10.0
        q = self._q(pts)
        keep = np.any(q != np.vstack((self.q[None, :], q[:-1])), axis=1)
        pts, piece, q, feed = pts[keep], piece[keep], q[keep], feed[keep]
        # planned end time of each line: the pen reaches the point at this time
        starts = np.concatenate(([0.0], np.cumsum(block.durations)[:-1]))
        s = np.linalg.norm(pts - verts[piece], axis=1)
        t_us = t0 + np.rint((starts[piece] + block.time_at(piece, s)) * 1e6).astype(np.int64)
        t_us = np.minimum(t_us, self.t_us)
        self.xy_m = verts[-1]
        if len(q):
            self.q = q[-1]
        n = len(q)
        self.lines_total += n
        if not emit or n == 0:
            return None
        text = []
        last = self.feed
        for (x, y), f in zip(q.tolist(), feed.tolist()):
            if f != last:
                text.append(f"G1X{fmt(x)}Y{fmt(y)}F{f:.1f}")
                last = f
            else:
                text.append(f"G1X{fmt(x)}Y{fmt(y)}")
        self.feed = last
        return Lines(text, block.line[piece].astype(np.int64), np.ones(n, dtype=bool), q,
                     self.kin.to_gcode(pts), block.drawing[piece].copy(), t_us)
