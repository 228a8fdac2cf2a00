"""Usage errors a newcomer makes: one line on stderr, exit 2, with the option or choice they
meant; `--version`; `--help` names every kind of input."""

from __future__ import annotations

import pytest

from vplotter.cli import main


def run(capsys, argv):
    try:
        code = main(argv)
    except SystemExit as e:        # --version exits through argparse
        code = int(e.code or 0)
    out, err = capsys.readouterr()
    return code, out, err


@pytest.mark.parametrize("argv, line", [
    (["draw", "car.ngc", "--widht", "300"],
     "vplotter draw: error: unknown option --widht; did you mean --width?"),
    (["info", "cat.jpg", "--max-tiem=2h"],
     "vplotter info: error: unknown option --max-tiem=2h; did you mean --max-time?"),
    (["draw", "cat.jpg", "--style", "hach"],
     "vplotter draw: error: --style hach: not a choice; did you mean hatch? (choose from "
     "spiral, hatch, stipple, squiggle, flow, auto)"),
    (["darw", "car.ngc"], "vplotter: error: 'darw' is not a command; did you mean 'draw'?"),
    (["pen", "dwon"], "vplotter pen: error: the action dwon: not a choice; did you mean down?"),
    (["convert", "car.ngc", "-o", "x.ngc", "--order", "fast"],
     "vplotter convert: error: --order fast: not a choice (choose from keep, greedy, best)"),
    (["draw"], "vplotter draw: error: the following arguments are required: file"),
    (["draw", "car.ngc", "extra.ngc"], "vplotter draw: error: unexpected argument 'extra.ngc'"),
])
def test_a_usage_error_is_one_line_with_a_suggestion(capsys, argv, line):
    code, out, err = run(capsys, argv)
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and err.startswith(line), err
    assert "usage:" not in err


def test_a_word_far_from_every_option_gets_no_guess(capsys):
    code, _, err = run(capsys, ["draw", "car.ngc", "--zzzzzz"])
    assert code == 2 and "did you mean" not in err and "--help lists the options" in err


def test_version(capsys):
    from vplotter import __version__

    code, out, _ = run(capsys, ["--version"])
    assert code == 0 and out.strip() == f"vplotter {__version__}"


def test_help_names_every_kind_of_input(capsys):
    code, out, _ = run(capsys, ["--help"])
    assert code == 0
    for kind in ("G-code", "SVG", "DXF", "text", "photos"):
        assert kind in out
    code, out, _ = run(capsys, ["draw", "--help"])
    assert all(k in out for k in ("G-code", "SVG", "DXF", "text", "photo"))
