"""gpiozero backend: any pin factory gpiozero supports (lgpio, RPi.GPIO, pigpio, native, mock),
timed in software by `realtime.Player` (absolute deadlines, sleep then spin).

Coils are DigitalOutputDevices (written through their `pin.state`, the fastest public path);
the pen is a gpiozero Servo whose min/max pulse widths are the pen's up/down widths, so
value -1/+1 give exactly those widths and value None stops the pulses. Servo needs a factory
with PWM (software PWM is fine); gpiozero's mock factory gets a PWM-capable mock pen pin
(GPIOZERO_PIN_FACTORY=mock simulates the whole machine).
"""

from __future__ import annotations

import warnings

from vplotter.backends import Backend
from vplotter.backends.realtime import Player
from vplotter.errors import BackendError
from vplotter.schedule import Rows

HINT = "use --dry-run to simulate, or GPIOZERO_PIN_FACTORY=mock"


class GpiozeroBackend(Backend):
    name = "gpiozero"

    def __init__(self, cfg, pin_factory=None, realtime: bool = True, clock=None, sleep=None,
                 **timing):
        """pin_factory: a gpiozero pin factory (default: gpiozero's own choice, or
        GPIOZERO_PIN_FACTORY); clock, sleep and timing options (spin_us, poll_us, ...) go to
        `realtime.Player`; realtime is accepted and ignored (always real time). The player
        writes one pin at a time in a legal order and keeps 1 / max_step_rate between two
        coil changes of one motor."""
        super().__init__(cfg)
        self.pin_factory = pin_factory
        self._coils = []
        self._servo = None
        lo, hi = sorted((cfg.pen.up_us, cfg.pen.down_us))
        self._pen_range = (lo, hi)
        timing = {"min_step_us": 1e6 / cfg.motors.max_step_rate, "pin_at_a_time": True, **timing}
        self._player = Player(self._write_coils, self._write_pen, clock, sleep, **timing)

    # -- outputs
    def _write_coils(self, word: int, changed: int) -> None:
        for bit, dev in enumerate(self._coils):
            if changed >> bit & 1:
                dev.pin.state = word >> bit & 1

    def _write_pen(self, pulse_us: int) -> None:
        if pulse_us <= 0:
            self._servo.value = None  # detach: no pulses
            return
        lo, hi = self._pen_range
        self._servo.value = max(-1.0, min(1.0, -1.0 + 2.0 * (pulse_us - lo) / (hi - lo)))

    # -- Backend
    def open(self) -> None:
        try:
            from gpiozero import DigitalOutputDevice
        except ImportError:
            raise BackendError(f"error: the gpiozero backend needs the gpiozero package; {HINT}") \
                from None
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # gpiozero warns about each factory it skips
                for pin in self.coil_pins:
                    self._coils.append(DigitalOutputDevice(pin, initial_value=False,
                                                           pin_factory=self.pin_factory))
        except Exception as e:  # noqa: BLE001 - BadPinFactory, GPIOPinInUse, ...
            pin = self.coil_pins[len(self._coils)]
            self.close()
            raise BackendError(f"error: gpiozero cannot drive GPIO{pin} ({type(e).__name__}: "
                               f"{e}); {HINT}") from None
        try:
            self._servo = self._make_servo(self._coils[0].pin_factory)
        except Exception as e:  # noqa: BLE001
            self.close()
            raise BackendError(f"error: gpiozero cannot make servo pulses on GPIO{self.pen_pin} "
                               f"({type(e).__name__}: {e}); use a pin factory with PWM "
                               f"(lgpio, pigpio, RPi.GPIO) or --dry-run") from None

    def _make_servo(self, factory):
        from gpiozero import Servo

        lo, hi = self._pen_range
        mock = _mock_without_pwm(factory)
        if mock is not None:
            factory.pin_class, old = mock, factory.pin_class
        try:
            return Servo(self.pen_pin, initial_value=None, min_pulse_width=lo / 1e6,
                         max_pulse_width=hi / 1e6, frame_width=0.02, pin_factory=factory)
        finally:
            if mock is not None:
                factory.pin_class = old

    def play(self, rows: Rows) -> int:
        return self._player.play(rows, lambda: self.stop_requested)

    def close(self) -> None:
        """All coils low, pen pulses off, pins released; never raises."""
        if self._servo is not None:
            for action in (self._servo.detach, self._servo.close):
                try:
                    action()
                except Exception:  # noqa: BLE001
                    pass
            self._servo = None
        for dev in self._coils:
            for action in (dev.off, dev.close):
                try:
                    action()
                except Exception:  # noqa: BLE001
                    pass
        self._coils = []

    def lateness(self) -> dict | None:
        return self._player.lateness.stats()


def _mock_without_pwm(factory):
    """gpiozero's MockFactory makes pins without PWM unless told otherwise: return the PWM
    mock pin class to use for the pen, or None for any other factory."""
    if type(factory).__name__ != "MockFactory":
        return None
    from gpiozero.pins.mock import MockPWMPin

    return None if issubclass(factory.pin_class, MockPWMPin) else MockPWMPin
