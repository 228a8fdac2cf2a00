"""Every command against every kind of bad input, in-process: the exit status is 0 or 2, stderr
never holds a traceback, and an error is exactly one line containing "error:"."""

from __future__ import annotations

from pathlib import Path

import pytest

from support.cli import GARBAGE, run

SAMPLES = Path(__file__).resolve().parent.parent / "gcode_samples"

# G-code inputs of the commands that read a file, and the exit status they must give.
GCODE = {
    "empty": (b"", 0),
    "one_line": (b"G1 X10 Y10\n", 0),
    "degenerate": (b"G0 X0 Y0\nG1 X0 Y0\nM3\nG1 X0 Y0\nG4 P0\nG2 X0 Y0 I5 J0\n"
                   b"G3 X0 Y0 I0 J-0.01\nG1 X0\nM5\nM5\nG0 X0 Y0\n", 0),
    "out_of_page": (b"G0 X10 Y10\nM3\nG1 X500 Y0\nM5\n", 2),
    "garbage": (GARBAGE, 2),
    "missing": (None, 2),
    "directory": ("dir", 2),
    "bad_config": (b"G1 X10 Y10\n", 2),
}


def _configs(seed: str) -> dict:
    """Config files for the commands that read no G-code: each kind of bad input, as config."""
    return {
        "empty": b"",
        "one_line": b"[machine]\n",
        "degenerate": seed.replace("x_max_mm = 200.0", "x_max_mm = -200.0").encode(),
        "out_of_page": seed.replace("y_max_mm = 300.0", "y_max_mm = 500.0").encode(),
        "garbage": GARBAGE,
        "missing": None,
        "directory": "dir",
        "bad_config": seed.replace("max_step_rate = 663", "max_step_rate = -5").encode(),
    }


FILE_COMMANDS = {"draw --dry-run": ["draw", "{file}", "--dry-run"],
                 "estimate": ["estimate", "{file}"],
                 "preview": ["preview", "{file}", "-o", "{file}.svg"]}
OTHER_COMMANDS = {"calibrate --at": ["calibrate", "--at", "0", "0"],
                  "calibrate --cords": ["calibrate", "--cords", "480", "480"],
                  "status": ["status"],
                  "pen up --dry-run": ["pen", "up", "--dry-run"]}


def _write(path: Path, content) -> str:
    """content: bytes to write, None for a missing file, "dir" for a directory."""
    if content == "dir":
        path.mkdir()
    elif content is not None:
        path.write_bytes(content)
    return str(path)


@pytest.mark.parametrize("kind", GCODE)
@pytest.mark.parametrize("command", FILE_COMMANDS)
def test_file_commands(capsys, tmp_path, config_path, command, kind):
    content, expected = GCODE[kind]
    cfg = str(config_path)
    if kind == "bad_config":
        cfg = _write(tmp_path / "config.toml",
                     config_path.read_bytes().replace(b"max_step_rate = 663", b"max_step_rate = -5"))
    gfile = _write(tmp_path / "input.ngc", content)
    argv = ["--config", cfg] + [a.format(file=gfile) for a in FILE_COMMANDS[command]]
    code, out, err = run(capsys, argv)
    assert code == expected, err
    if code == 0:
        assert f"{gfile}: " in out and "plot time" in out
    elif kind == "bad_config":
        assert "[motors] max_step_rate must be above 0 (got -5)" in err
    elif kind in ("out_of_page", "garbage"):
        assert f"{gfile}:" in err


@pytest.mark.parametrize("kind", list(GCODE))
@pytest.mark.parametrize("command", OTHER_COMMANDS)
def test_other_commands_with_bad_config(capsys, tmp_path, config_path, command, kind):
    content = _configs(config_path.read_text(encoding="utf-8"))[kind]
    cfg = _write(tmp_path / "config.toml", content)
    code, _, err = run(capsys, ["--config", cfg, *OTHER_COMMANDS[command]])
    assert code == 2, err
    assert cfg in err


@pytest.mark.parametrize("command", OTHER_COMMANDS)
def test_other_commands_with_the_seed_config(capsys, config_path, command):
    code, out, _ = run(capsys, ["--config", config_path, *OTHER_COMMANDS[command]])
    assert code == 0 and out


ARGUMENTS = [
    # (argv after --config, exit status)
    (["calibrate", "--at", "0", "430"], 2),      # on the anchor line
    (["calibrate", "--at", "0", "500"], 2),      # above the anchors
    (["calibrate", "--at", "nan", "nan"], 2),
    (["calibrate", "--cords", "100", "100"], 2),  # too short to meet below the anchors
    (["calibrate", "--cords", "-300", "300"], 2),
    (["calibrate", "--cords", "100", "600"], 2),  # differ by more than the anchor distance
    (["calibrate", "--cords", "nan", "300"], 2),
    (["calibrate", "--at", "inf", "0"], 2),
    (["calibrate", "--cords", "1e300", "1e300"], 2),
    (["calibrate", "--at", "0"], 2),             # argparse: usage error
    (["calibrate", "--at", "x", "0"], 2),
    (["calibrate"], 2),
    (["draw"], 2),
    (["pen", "sideways"], 2),
    (["frobnicate"], 2),
    (["--help"], 0),
]


@pytest.mark.parametrize("argv,expected", ARGUMENTS)
def test_bad_arguments(capsys, config_path, argv, expected):
    code, _, err = run(capsys, ["--config", config_path, *argv])
    assert code == expected, err


@pytest.mark.parametrize("argv", [["status"], ["pen", "up", "--dry-run"],
                                  ["draw", "{sample}", "--dry-run"], ["estimate", "{sample}"]])
def test_corrupt_stored_position(capsys, tmp_path, config_path, argv):
    state = tmp_path / "state" / "vplotter" / "state.json"
    state.parent.mkdir(parents=True)
    state.write_text("{not json")
    sample = SAMPLES / "square.ngc"
    code, _, err = run(capsys, ["--config", config_path, *[a.format(sample=sample) for a in argv]])
    assert code == 2 and str(state) in err


def test_calibrate_then_status(capsys, config_path):
    assert run(capsys, ["--config", config_path, "calibrate", "--at", "10", "20"])[0] == 0
    code, out, _ = run(capsys, ["--config", config_path, "status"])
    assert code == 0 and "pen at X10.000 Y20.000" in out


def test_strict_makes_spiral_warnings_errors(capsys, tmp_path, config_path):
    g = _write(tmp_path / "spiral.ngc", b"G0 X0 Y0\nG2 X10 Y10.5 I10\n")
    code, _, err = run(capsys, ["--config", config_path, "estimate", g])
    assert code == 0 and f"{g}:2:1: warning: arc end radius" in err
    code, _, err = run(capsys, ["--config", config_path, "estimate", g, "--strict"])
    assert code == 2 and f"{g}:2:1: error: arc end radius" in err


@pytest.mark.parametrize("sample", sorted(SAMPLES.glob("*.ngc")), ids=lambda p: p.name)
def test_every_sample_draws(capsys, config_path, sample):
    code, out, _ = run(capsys, ["--config", config_path, "draw", sample, "--dry-run"])
    assert code == 0 and "plot time" in out


def test_help_is_fast_and_imports_nothing_heavy():
    """`vplotter --help` must not import numpy, gpiozero, lgpio (a Pi Zero takes seconds)."""
    import subprocess
    import sys

    code = ("import sys; from vplotter.cli import main; rc = main(['--help']); "
            "heavy = [m for m in ('numpy', 'gpiozero', 'lgpio', 'tomlkit', 'svgelements', "
            "'PIL', 'serial') if m in sys.modules]; "
            "print(heavy); sys.exit(rc)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert out.returncode == 0
    assert out.stdout.strip().splitlines()[-1] == "[]"
    assert "draw" in out.stdout and "calibrate" in out.stdout


def test_python_dash_m_works(config_path, tmp_path):
    import os
    import subprocess
    import sys

    env = dict(os.environ, XDG_STATE_HOME=str(tmp_path))
    out = subprocess.run([sys.executable, "-m", "vplotter", "--config", str(config_path), "estimate",
                          str(config_path.parent / "gcode_samples" / "square.ngc")],
                         capture_output=True, text=True, env=env)
    assert out.returncode == 0 and "plot time" in out.stdout
