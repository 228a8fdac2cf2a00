"""Shared test fixtures: no test touches the real home directory; hypothesis is deterministic.

The helpers the tests share (REPO, tracecheck, the stand-ins) are in tests/support/."""

import os
import shutil
import tempfile
from pathlib import Path

import pytest
from hypothesis import settings

from support import REPO

# helpers whose asserts check what a test sees: rewritten as the tests' own are, so a failure
# shows the values
pytest.register_assert_rewrite("support.cli", "support.web")

settings.register_profile("vplotter", derandomize=True, database=None, deadline=None)
settings.load_profile("vplotter")


MEMORY = Path("/dev/shm")


@pytest.fixture(scope="session")
def _in_memory():
    """A folder in memory (tmpfs) for the stored positions, where the machine has one: a draw
    fsyncs each journal record (5 ms each on this machine's disk under load, 1,800 of them
    for the calibration pattern), which costs nothing there. None: no such folder."""
    if not (MEMORY.is_dir() and os.access(MEMORY, os.W_OK)):
        yield None
        return
    root = Path(tempfile.mkdtemp(prefix="vplotter-tests-", dir=MEMORY))
    yield root
    shutil.rmtree(root, ignore_errors=True)


def state_dir(where: Path, memory: Path | None) -> Path:
    """`where`, a fresh directory for the stored position: a link to one in memory if any."""
    if memory is not None:
        where.symlink_to(tempfile.mkdtemp(dir=memory), target_is_directory=True)
    return where


@pytest.fixture(autouse=True)
def _state_home(tmp_path, monkeypatch, _in_memory):
    """The stored pen position goes to a fresh directory (tmp_path / "state"), never to
    ~/.local/state."""
    monkeypatch.setenv("XDG_STATE_HOME", str(state_dir(tmp_path / "state", _in_memory)))


@pytest.fixture
def config_path() -> Path:
    """The repository's config.toml (the seed machine)."""
    return REPO / "config.toml"
