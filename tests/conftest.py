"""Shared test fixtures: no test touches the real home directory; hypothesis is deterministic.

The helpers the tests share (REPO, tracecheck, the stand-ins) are in tests/support/."""

from pathlib import Path

import pytest
from hypothesis import settings

from support import REPO

# helpers whose asserts check what a test sees: rewritten as the tests' own are, so a failure
# shows the values
pytest.register_assert_rewrite("support.cli", "support.web")

settings.register_profile("vplotter", derandomize=True, database=None, deadline=None)
settings.load_profile("vplotter")


@pytest.fixture(autouse=True)
def _state_home(tmp_path, monkeypatch):
    """The stored pen position goes to a fresh directory, never to ~/.local/state."""
    monkeypatch.setenv("XDG_STATE_HOME", str(tmp_path / "state"))


@pytest.fixture
def config_path() -> Path:
    """The repository's config.toml (the seed machine)."""
    return REPO / "config.toml"
