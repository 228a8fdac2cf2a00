"""The pen options of the commands that take a drawing file (--pen-order, --refill-every),
kept free of numpy so that building the command line stays fast (see drawing/pens.py)."""

from __future__ import annotations

import argparse
import math

ORDERS = ("light-to-dark", "file")


def parse_distance(text: str) -> float:
    """'80m', '500cm', '1200mm' or a plain number of metres -> mm (ValueError if not one, or
    not above 0)."""
    t = text.strip().lower()
    for unit, mm in (("mm", 1.0), ("cm", 10.0), ("m", 1000.0), ("", 1000.0)):
        if t.endswith(unit):
            try:
                v = float(t[:len(t) - len(unit)]) * mm
            except ValueError:
                break
            if math.isfinite(v) and v > 0:
                return v
            break
    raise ValueError(f"a distance above 0 such as 80m, 500cm or 1200mm (got {text!r})")


def _distance(text: str) -> float:
    try:
        return parse_distance(text)
    except ValueError as e:
        raise argparse.ArgumentTypeError(f"--refill-every must be {e}") from None


def add(group) -> None:
    """--pen-order and --refill-every, in the file options' order group."""
    group.add_argument("--pen-order", choices=ORDERS,
                       help="the order of a drawing's pens: light to dark (default: no dark "
                            "line smeared by a later light pen) or as the file first uses them")
    group.add_argument("--refill-every", type=_distance, metavar="DIST",
                       help="pause for a fresh pen every DIST drawn with one pen (80m, 500cm, "
                            "1200mm; a plain number is metres)")
