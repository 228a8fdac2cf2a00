"""The command line run in-process the way a person sees it (test_cli_errors.py,
test_preview_simulate.py).

- ``run``: `vplotter ARGV` in-process; its exit status, stdout and stderr, having checked that
  no traceback shows and that a failure says exactly one line with "error:" (none on success);
- ``GARBAGE``: 400 random bytes (a fixed seed), a file that is no kind of input."""

from __future__ import annotations

import random

from vplotter.cli import main

GARBAGE = random.Random(20190).randbytes(400)


def run(capsys, argv: list[str]) -> tuple[int, str, str]:
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    assert "Traceback" not in err and "Traceback" not in out
    errors = [line for line in err.splitlines() if "error:" in line]
    if code == 0:
        assert errors == [], err
    else:
        assert len(errors) == 1, err
    return code, out, err
