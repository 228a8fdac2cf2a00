"""The serial backend: a grbl-style controller on a serial port plays G-code lines.

This module opens the port and checks that the controller is ready; `grbl` speaks the
protocol, and `machine.serial_job.SerialSession` runs a draw on it (its "schedule" is a line
stream, `motion.linestream`).

pyserial is imported here only, when a port is opened.
"""

from __future__ import annotations

from vplotter.backends.base import Backend
from vplotter.backends.grbl import READ_TIMEOUT_S, Link
from vplotter.errors import BackendError


def open_port(cfg, timeout_s: float | None = None) -> Link:
    """Open [serial] port and wait for the controller's start-up banner."""
    try:
        import serial
    except ImportError:
        raise BackendError("pyserial is not installed (pip install pyserial)") from None
    ser = cfg.serial
    try:
        port = serial.Serial(ser.port, ser.baud, timeout=READ_TIMEOUT_S,
                             write_timeout=ser.timeout_s)
    except (serial.SerialException, OSError, ValueError) as e:
        raise BackendError(f"cannot open the serial port {ser.port}: {e}") from None
    link = Link(port, ser.port, ser.timeout_s)
    try:
        link.wait_banner(timeout_s)
    except BaseException:
        _close(port)
        raise
    return link


def _close(port) -> None:
    try:
        port.close()
    except Exception:  # noqa: BLE001 - closing must never raise
        pass


class SerialBackend(Backend):
    """Opens the port (or, in a dry run, nothing) and checks that the controller is ready."""

    name = "serial"

    def __init__(self, cfg, dry_run: bool = False):
        super().__init__(cfg)
        self.dry_run = dry_run
        self.link: Link | None = None

    def open(self) -> None:
        if self.dry_run:
            return
        self.link = open_port(self.cfg)
        try:
            st = self.link.status()
        except BaseException:
            self.close()
            raise
        if st.state == "Alarm":
            self.close()
            raise BackendError(f"the controller on {self.cfg.serial.port} is in its alarm state "
                               f"(it lost its position or wants homing); put the pen where "
                               f"vplotter thinks it is, then unlock it with $X in "
                               f"`vplotter serial console`")
        if not st.state.startswith(("Idle", "Hold")):
            self.close()
            raise BackendError(f"the controller on {self.cfg.serial.port} is busy ({st.state})")

    def play(self, rows) -> int:
        raise BackendError("the serial backend streams drawings: use it with `vplotter draw`")

    def close(self) -> None:
        if self.link is not None:
            _close(self.link.port)
            self.link = None
