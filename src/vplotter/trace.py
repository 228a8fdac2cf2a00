"""GPIO trace v1: every output change as `t,pin,value` rows (a contract other tools read).

    # vplotter trace v1
    t,pin,value
    0.000000,0,0

t = seconds since the start, pin = BCM number, value = 0/1 for the motor pins (coils, or STEP,
DIR and ENABLE) and the pulse width in microseconds for the pen pin (0 = pulses off; the
codes 1 = up, 2 = down for solenoid and cam pens). The first rows give every pin at t = 0;
rows with equal t take effect together.
"""

from __future__ import annotations

from typing import TextIO

import numpy as np

from vplotter.schedule import Rows

HEADER = "# vplotter trace v1\nt,pin,value\n"


class TraceWriter:
    def __init__(self, out: TextIO, coil_pins: list[int], pen_pin: int):
        self.out = out
        self.coil_pins = np.asarray(coil_pins, dtype=np.int64)
        self.pen_pin = pen_pin
        self.coils: int | None = None
        self.pen = 0
        out.write(HEADER)

    def comment(self, text: str) -> None:
        for line in text.splitlines():
            self.out.write(f"# {line}\n")

    def write(self, rows: Rows) -> None:
        if len(rows) == 0:
            return
        words = rows.coils.astype(np.int64)
        pens = rows.pen_us.astype(np.int64)
        if self.coils is None:
            # the first rows give the initial level of every pin
            init = [f"{_t(int(rows.t_us[0]))},{int(p)},{(int(words[0]) >> b) & 1}"
                    for b, p in enumerate(self.coil_pins)]
            init.append(f"{_t(int(rows.t_us[0]))},{self.pen_pin},{int(pens[0])}")
            self.out.write("\n".join(init) + "\n")
            self.coils, self.pen = int(words[0]), int(pens[0])
            rows = rows[1:]
            words, pens = words[1:], pens[1:]
            if len(words) == 0:
                return
        prev_w = np.concatenate(([self.coils], words[:-1]))
        prev_p = np.concatenate(([self.pen], pens[:-1]))
        changed = (prev_w ^ words)
        bits = ((changed[:, None] >> np.arange(len(self.coil_pins))) & 1).astype(bool)
        r_idx, b_idx = np.nonzero(bits)
        vals = (words[r_idx] >> b_idx) & 1
        pen_idx = np.flatnonzero(prev_p != pens)
        # merge coil and pen changes in row order (pen after coils within a row)
        ridx = np.concatenate((r_idx, pen_idx))
        pins = np.concatenate((self.coil_pins[b_idx], np.full(len(pen_idx), self.pen_pin)))
        values = np.concatenate((vals, pens[pen_idx]))
        key = np.concatenate((r_idx * 2, pen_idx * 2 + 1))
        order = np.argsort(key, kind="stable")
        t = rows.t_us[ridx[order]]
        sec, usec = np.divmod(t, 1_000_000)
        lines = [f"{s}.{u:06d},{p},{v}\n" for s, u, p, v in
                 zip(sec.tolist(), usec.tolist(), pins[order].tolist(), values[order].tolist())]
        self.out.write("".join(lines))
        self.out.flush()       # what was played is on disk, even if the process is killed
        self.coils, self.pen = int(words[-1]), int(pens[-1])


def _t(t_us: int) -> str:
    return f"{t_us // 1_000_000}.{t_us % 1_000_000:06d}"
