"""Signals mid-draw without sleeping, and the short drawing the real-time stops draw.

- ``interrupt_after``: the fake backend receives a signal after playing a given number of rows
  (test_safety.py, test_motor_release.py, test_stepdir.py, test_polar_plotter.py,
  test_prepare.py);
- ``hold_lock``: another process holding the plotter lock (test_safety.py, test_first_run.py);
- ``SHORT``: a few millimetres with an arc, drawn in real time on mock pins and stopped
  (test_safety.py, test_live.py)."""

import os
import subprocess
import sys

from vplotter.backends.fake import FakeBackend

SHORT = """G21 G90
G00 Z5
G00 X2 Y2
G01 Z-1 F600
G01 X6 Y2
G01 X6 Y6
G02 X2 Y6 R2
G01 X2 Y2
G00 Z5
G00 X0 Y0
M2
"""


def interrupt_after(monkeypatch, rows_before_signal, signum):
    """Make the fake backend receive `signum` after playing that many rows in total."""
    played = {"n": 0, "sent": False}
    orig = FakeBackend.play

    def play(self, rows):
        left = rows_before_signal - played["n"]
        if self.stop_requested:
            return 0
        if not played["sent"] and 0 <= left < len(rows):
            played["sent"] = True
            os.kill(os.getpid(), signum)        # handled before the next line runs
            part = rows[:left]
            played["n"] += left
            return orig(self, part) if left else 0
        played["n"] += len(rows)
        return orig(self, rows)

    monkeypatch.setattr(FakeBackend, "play", play)
    return orig


HOLD = r"""
import sys
from vplotter.machine import lock
lock.acquire(sys.argv[1])
print("held", flush=True)
sys.stdin.read()
"""


def hold_lock(command):
    """Another process holding the plotter lock until its stdin closes."""
    proc = subprocess.Popen([sys.executable, "-c", HOLD, command], stdin=subprocess.PIPE,
                            stdout=subprocess.PIPE, text=True, env=dict(os.environ))
    assert proc.stdout.readline() == "held\n"
    return proc
