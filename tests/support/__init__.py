"""What the tests share besides pytest's fixtures (those stay in tests/conftest.py).

- ``REPO``: the repository's root.
- ``tracecheck/``: the independent trace decoder and verifier (imports nothing of vplotter).
- ``fake_lgpio.py``: a stand-in lgpio as unkind as lgpio 0.2.2, on a simulated clock.
- ``grbl_standin.py``: a grbl 1.1 stand-in on a pseudo-terminal pair.
- ``bezier_svg.py``: SVGs of smooth cubic Béziers with their true curves.
- ``wall.py``: the simulated wall of the wall-calibration tests (and bench/wall_fit.py).
- ``phone_photo.py``: phone photos of a drawing on that wall (test_calibrate_photo.py and
  bench/calibrate_photo.py).
- the helpers of more than one test file (no test file imports another): ``backends.py``
  (a short drawing in the parts a backend gets, rows, gpiozero's mock pins), ``signals.py``
  (``interrupt_after``, ``SHORT``), ``cli.py`` (``run``, ``GARBAGE``), ``stepdir.py``
  (``stepdir_toml``), ``web.py`` (the ``serve`` fixture and ``Server``).

The tests import it as ``support`` (pytest puts tests/ on the path); the bench scripts, run as
``python -m bench.NAME`` from the repository's root, as ``tests.support``.
"""

from pathlib import Path

REPO = Path(__file__).resolve().parent.parent.parent
