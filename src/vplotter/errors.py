"""Errors meant for people: one line each, and the exit status that goes with them."""


class VplotterError(Exception):
    """Base of every error vplotter reports to the user (exit status `exit_code`)."""

    exit_code = 1


class InputError(VplotterError, ValueError):
    """Bad drawing input: the message starts with file:line:col."""

    exit_code = 2


def unreadable(path, e: OSError, what: str = "a drawing file") -> InputError:
    """The one line for a file that cannot be opened: missing, a directory (not `what`), or
    the system's reason."""
    if isinstance(e, FileNotFoundError):
        why = "no such file"
    elif isinstance(e, IsADirectoryError):
        why = f"is a directory, not {what}"
    else:
        why = f"cannot read: {e.strerror or e}"
    return InputError(f"{path}: error: {why}")


class ConfigError(VplotterError, ValueError):
    """Bad config.toml or command-line values."""

    exit_code = 2


class MachineError(VplotterError):
    """The machine cannot do what was asked (position unknown, outside the page...)."""

    exit_code = 2


class StateError(VplotterError):
    """The stored position is missing, corrupt or not trustworthy."""

    exit_code = 2


class BackendError(VplotterError, RuntimeError):
    """The GPIO backend cannot be opened or failed while driving."""

    exit_code = 1


class BusyError(VplotterError):
    """Another vplotter process holds the plotter; `holder` is the lock file's {"pid",
    "command", "since"} (`machine.live.busy_line` adds the draw's progress to the message)."""

    exit_code = 3

    def __init__(self, message: str, holder: dict | None = None):
        super().__init__(message)
        self.holder = holder or {}


class Interrupted(VplotterError):
    """A signal stopped the machine; exit status 128 + signal number."""

    def __init__(self, message: str, signum: int):
        super().__init__(message)
        self.signum = signum
        self.exit_code = 128 + signum
