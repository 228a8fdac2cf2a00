"""Coil sequences of a unipolar stepper (28BYJ-48 on a ULN2003 board).

A pattern is 4 bits, bit 0 = IN1 ... bit 3 = IN4. Stepping "forward" walks the table upwards.
The two motors share one 8-bit coil word: bits 0-3 the left motor, bits 4-7 the right one.
"""

from __future__ import annotations

import numpy as np


def _bits(*rows: str) -> np.ndarray:
    # "1100" means IN1 and IN2 on
    return np.array([sum(1 << i for i, c in enumerate(r) if c == "1") for r in rows],
                    dtype=np.uint8)


TABLES = {
    "half": _bits("1000", "1100", "0100", "0110", "0010", "0011", "0001", "1001"),
    "full": _bits("1100", "0110", "0011", "1001"),
    "wave": _bits("1000", "0100", "0010", "0001"),
}


def coil_words(table: np.ndarray, phase_left: np.ndarray, phase_right: np.ndarray) -> np.ndarray:
    """Coil words for per-row phase indices of both motors."""
    n = len(table)          # 8 or 4: a power of two
    return table[phase_left & (n - 1)] | (table[phase_right & (n - 1)] << np.uint8(4))

