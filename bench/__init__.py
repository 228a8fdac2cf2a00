"""The scripts behind docs/measurements.md and the figures the other pages quote: the
benchmarks here, the generators of test drawings in make/, the independent references in
reference/. Run them from the repository's root as modules (`python -m bench.plan_speed`);
bench/README.md lists them all."""

from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent   # the repository's root


def start_of(cfg):
    """Where the benchmarks' dry runs start: the motor counts (0, 0) with the pen at G-code
    X0 Y0, and the motor coordinates there."""
    from vplotter import kinematics

    kin = kinematics.from_config(cfg)
    return (0, 0), kin.inverse(kin.to_machine([[0.0, 0.0]]))[0]


def test_support(name: str):
    """The module NAME of tests/support/ ("tracecheck", "bezier_svg", "wall"), imported as
    `support.NAME`, the way the tests import it. Not `import tests.support`: a `tests` package
    that some distributions install into site-packages would shadow the repository's folder."""
    import importlib
    import importlib.util
    import sys

    if "support" not in sys.modules:
        folder = ROOT / "tests" / "support"
        spec = importlib.util.spec_from_file_location(
            "support", folder / "__init__.py", submodule_search_locations=[str(folder)])
        module = importlib.util.module_from_spec(spec)
        sys.modules["support"] = module
        spec.loader.exec_module(module)
    return importlib.import_module(f"support.{name}")
