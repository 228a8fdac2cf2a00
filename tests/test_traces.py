"""Every drawing the repository ships, drawn dry with a GPIO trace (and one streamed to a grbl
controller), hashed against tests/data/trace_hashes.json: a restructuring changes none of
them, byte for byte. The trace's comment lines (which name the file) are left out of the hash.

A change that means to change plans updates the file, in a commit that says why:

    python tests/test_traces.py --update
"""

from __future__ import annotations

import hashlib
import json
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent
HASHES = REPO / "tests" / "data" / "trace_hashes.json"
POLAR = ["--config", "examples/polar.toml"]
WALL2M = ["--config", "tests/data/wall2m.toml"]


def _cases() -> dict[str, list[str]]:
    cases: dict[str, list[str]] = {}
    for folder in ("gcode_samples", "svg_samples", "tests/data"):
        for p in sorted((REPO / folder).glob("*.ngc")) + sorted((REPO / folder).glob("*.svg")):
            cases[f"{folder}/{p.name}"] = ["draw", f"{folder}/{p.name}"]
    for p in sorted((REPO / "gcode_samples" / "polar").glob("*.ngc")):
        cases[f"polar/{p.name}"] = POLAR + ["draw", f"gcode_samples/polar/{p.name}"]
    cases.update({
        "car best fit rotated": ["draw", "gcode_samples/car.ngc", "--order", "best", "--fit",
                                 "--rotate", "30", "--margin", "10"],
        "car from line 120": ["draw", "gcode_samples/car.ngc", "--from-line", "120"],
        "car on a 2 m wall": WALL2M + ["draw", "gcode_samples/car.ngc"],
        "polar svg fit": POLAR + ["draw", "svg_samples/units_symbols.svg", "--fit"],
        "layers paused, refilled": ["draw", "svg_samples/inkscape_layers.svg",
                                    "--pause-between-layers", "--refill-every", "0.2m"],
        "symbols hatched": ["draw", "svg_samples/units_symbols.svg", "--fill", "hatch",
                            "--fill-spacing", "2"],
        "strokes greedy aligned": ["draw", "gcode_samples/strokes.ngc", "--order", "greedy",
                                   "--align", "left", "--valign", "top", "--margin", "5"],
        "dxf": ["draw", "tests/data/inputs/shapes.dxf"],
        "text file": ["draw", "tests/data/inputs/hello.txt"],
        "photo hatch": ["draw", "tests/data/images/exif6.jpg", "--width", "80", "--spacing",
                        "4"],
        "photo spiral": ["draw", "tests/data/images/gray16.png", "--width", "60", "--spacing",
                         "3", "--style", "spiral"],
    })
    return cases


CASES = _cases()
SERIAL = {"grbl car": ["draw", "gcode_samples/car.ngc", "--backend", "serial"]}


def digest(argv: list[str], out: Path) -> str:
    """The sha256 of what `vplotter ARGV --dry-run` plays: the trace's data lines, or the
    lines streamed to a grbl controller."""
    from vplotter import cli

    serial = "serial" in argv
    extra = ["--save-stream", str(out)] if serial else ["--trace", str(out)]
    code = cli.main(argv + ["--dry-run"] + extra)
    assert code == 0, argv
    h = hashlib.sha256()
    with open(out, "rb") as f:
        for line in f:
            if not line.startswith(b"#"):
                h.update(line)
    return h.hexdigest()


@pytest.mark.parametrize("name", [*CASES, *SERIAL])
def test_the_trace_is_unchanged(name, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(REPO)
    expected = json.loads(HASHES.read_text())
    assert digest({**CASES, **SERIAL}[name], tmp_path / "out") == expected[name]


def _update() -> None:
    import os
    import tempfile

    os.chdir(REPO)
    os.environ["XDG_STATE_HOME"] = tempfile.mkdtemp()
    hashes = {}
    with tempfile.TemporaryDirectory() as tmp:
        for name, argv in {**CASES, **SERIAL}.items():
            hashes[name] = digest(argv, Path(tmp) / "out")
            print(name, hashes[name][:12], file=sys.stderr)
    HASHES.write_text(json.dumps(hashes, indent=1) + "\n")


if __name__ == "__main__" and sys.argv[1:] == ["--update"]:
    _update()
