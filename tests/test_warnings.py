"""Warnings of one kind become one line with a count and the first place."""

from __future__ import annotations

import pytest
from hypothesis import given, strategies as st

from vplotter.commands.warnings import Collector


def arc(line: int, r0: float, r1: float) -> str:
    return (f"car.ngc:{line}:5: warning: arc end radius {r1:.4f} differs from start radius "
            f"{r0:.4f} by {abs(r1 - r0):.4f} mm; drawing a spiral")


def collected(messages, verbose=False) -> list[str]:
    lines: list[str] = []
    c = Collector(verbose=verbose, out=lines.append)
    for m in messages:
        c(m)
    c.flush()
    return lines


def test_many_arcs_are_one_line_with_the_count_and_the_first_place():
    lines = collected([arc(12 + i, 10.0, 11.0 + i) for i in range(500)])
    assert lines == ["car.ngc: warning: 500 arcs whose end radius differs from the start "
                     "(first at 12:5): drawn as spirals; --verbose lists them"]


def test_one_warning_is_printed_as_it_was_given():
    assert collected([arc(7, 1.0, 2.0)]) == [arc(7, 1.0, 2.0)]


def test_kinds_keep_the_order_they_first_came_in():
    other = "car.ngc:3:1: warning: <use> target '#a' not found"
    lines = collected([arc(2, 1, 2), other, arc(9, 1, 3), "car.ngc: warning: program ended"])
    assert [ln.split(": warning: ")[1][:9] for ln in lines] == ["2 arcs wh", "<use> tar",
                                                                "program e"]


def test_an_unknown_kind_that_repeats_is_counted_too():
    lines = collected([f"a.svg:{i}:1: warning: <use> target '#n{i}' not found" for i in (4, 8)])
    assert lines == ["a.svg: warning: 2 warnings like this one at 4:1: <use> target '#n4' not "
                     "found; --verbose lists them"]


def test_verbose_lists_every_warning_as_it_comes():
    msgs = [arc(i, 1, 2) for i in range(1, 4)]
    assert collected(msgs, verbose=True) == msgs


def test_a_failed_command_drops_what_it_held():
    lines: list[str] = []
    c = Collector(out=lines.append)
    c(arc(1, 1, 2))
    c.drop()
    c.flush()
    assert lines == []


@given(st.lists(st.tuples(st.sampled_from(["a.ngc", "b.svg"]), st.integers(1, 10**6),
                          st.floats(0, 1e4, allow_nan=False)), max_size=60))
def test_every_warning_is_counted_once(items):
    msgs = [f"{f}:{n}:1: warning: arc end radius {r:.4f} differs from start radius 0.0000 by "
            f"{r:.4f} mm; drawing a spiral" for f, n, r in items]
    lines = collected(msgs)
    total = sum(int(ln.split(": warning: ")[1].split()[0]) if "--verbose" in ln else 1
                for ln in lines)
    assert total == len(msgs) and len(lines) == len({f for f, _, _ in items})


# ------------------------------------------------------------------ as a person sees them
def _cli(capsys, argv):
    from vplotter.cli import main

    from support import REPO

    code = main(["--config", str(REPO / "config.toml"), *argv])
    out, err = capsys.readouterr()
    return code, out, err


def test_the_quick_start_prints_no_warning(capsys):
    from support import REPO

    code, out, err = _cli(capsys, ["draw", str(REPO / "gcode_samples" / "car.ngc"), "--dry-run"])
    assert code == 0 and "plot time" in out
    assert "warning" not in err


def test_five_hundred_arc_warnings_are_one_line(capsys, tmp_path):
    lines = ["G0 X-100 Y0", "M3"]
    for i in range(1, 1001):                   # every other move an arc ending off its radius
        x = i * 0.25 - 100
        lines.append(f"G2 X{x:g} Y0 I0.05 J-3" if i % 2 else f"G1 X{x:g} Y0")
    f = tmp_path / "many.ngc"
    f.write_text("\n".join(lines) + "\nM5\n")
    for command in (["estimate", str(f)], ["draw", str(f), "--dry-run"],
                    ["convert", str(f), "-o", str(tmp_path / "o.ngc"), "--scale", "0.5"]):
        code, _, err = _cli(capsys, command)
        warned = [ln for ln in err.splitlines() if ": warning:" in ln]
        assert code == 0 and len(warned) == 1, err
        assert warned[0].startswith(f"{f}: warning: 500 arcs whose end radius differs from the "
                                    f"start (first at 3:1): drawn as spirals")
    code, _, err = _cli(capsys, ["estimate", str(f), "--strict"])      # an error: one line
    assert code == 2 and err.count("\n") <= 2 and ": warning:" not in err


@pytest.mark.parametrize("command", [["convert", "{f}", "-o", "{tmp}/o.ngc"],
                                     ["draw", "{f}", "--dry-run"], ["info", "{f}"],
                                     ["estimate", "{f}"], ["preview", "{f}", "-o", "{tmp}/p.png"]])
@pytest.mark.parametrize("name, body", [("missing.svg", None), ("broken.ngc", b"G1 X1 Y\n"),
                                        ("empty.png", b""), ("bad.svg", b"<svg><path d='M 0'")])
def test_a_bad_file_on_a_fresh_install_is_one_line(capsys, tmp_path, command, name, body):
    """No stored position: the dry run's note about X0 Y0 would come after the file is read,
    and a failed command says only its error."""
    f = tmp_path / name
    if body is not None:
        f.write_bytes(body)
    argv = [a.format(f=f, tmp=tmp_path) for a in command]
    code, out, err = _cli(capsys, argv)
    assert code == 2 and err.count("\n") == 1 and "error:" in err, err
    assert "note:" not in err and out == ""


def test_the_dry_run_note_comes_after_the_file_is_read(capsys, tmp_path):
    f = tmp_path / "arcs.ngc"
    f.write_text("G0 X0 Y0\nM3\nG2 X1 Y0 I0.05 J-3\nG2 X2 Y0 I0.05 J-3\nM5\n")
    code, out, err = _cli(capsys, ["draw", str(f), "--dry-run"])
    lines = err.splitlines()
    assert code == 0 and lines[0].startswith("note: no calibrated position stored")
    assert lines[1].startswith(f"{f}: warning: 2 arcs") and "plot time" in out
