"""gpiozero backend: any pin factory gpiozero supports (lgpio, RPi.GPIO, pigpio, native, mock),
timed in software by `realtime.Player` (absolute deadlines, sleep then spin).

Coils are DigitalOutputDevices (written through their `pin.state`, the fastest public path). The
pen: on gpiozero's lgpio factory (what gpiozero uses on a Pi) the player writes the servo pulses
itself through lgpio (`realtime.Player`'s pulse trains: the configured width to the microsecond,
every pulse whole), because gpiozero sets PWM through a duty cycle in whole percent (gpiozero issue
1209: 500 us is sent as 400 us). Other factories get a gpiozero Servo whose min/max pulse widths are
the pen's up/down widths (value -1/+1, None stops the pulses); it needs a factory with PWM (software
PWM is fine); gpiozero's mock factory gets a PWM-capable mock pen pin (GPIOZERO_PIN_FACTORY=mock
simulates the whole machine).
"""

from __future__ import annotations

import contextlib
import os
import sys
import time
import warnings

from vplotter.backends import memory
from vplotter.backends.base import Backend, servo_widths
from vplotter.backends.realtime import Player
from vplotter.errors import BackendError
from vplotter.motion.schedule import Rows

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
        self._pen_dev = None                 # the pen pin on the lgpio factory
        self._kind_pen = None                # a solenoid or a cam (pens.py)
        self._pen_devices = []
        widths = servo_widths(cfg)             # [pens.NAME] down_us: per-pen pen-down pulses
        lo, hi = min(widths), max(widths)
        self._pen_range = (lo, hi)
        self._clock, self._sleep = clock or time.perf_counter_ns, sleep or time.sleep
        # coils: one pin at a time in a legal order, 1 / max_step_rate between two changes of
        # one motor; step/dir words (STEP, DIR of both motors, ENABLE) keep their planned
        # intervals (a STEP pulse is 2 us, DIR is set 1 us before it)
        coils = cfg.motors.driver == "uln2003"
        timing = {"min_step_us": 1e6 / cfg.motors.max_step_rate if coils else 0,
                  "pin_at_a_time": coils, **timing}
        self._player = Player(self._write_coils, self._write_pen, self._clock, self._sleep,
                              **timing)
        self._player.coils = self.idle_word

    # -- outputs
    def _write_coils(self, word: int, changed: int) -> None:
        for bit, dev in enumerate(self._coils):
            if changed >> bit & 1:
                dev.pin.state = word >> bit & 1

    def _write_pen(self, pulse_us: int) -> None:
        if self._kind_pen is not None:       # a solenoid or the cam (pens.py)
            self._kind_pen.set(pulse_us)
            return
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
        prepared = self._prepare_lgpio()
        memory.lean_malloc()
        try:
            with warnings.catch_warnings(), prepared:
                warnings.simplefilter("ignore")  # gpiozero warns about each factory it skips
                for bit, pin in enumerate(self.coil_pins):
                    idle = bool(self.idle_word >> bit & 1)     # ENABLE high for step/dir
                    self._coils.append(DigitalOutputDevice(pin, initial_value=idle,
                                                           pin_factory=self.pin_factory))
        except Exception as e:  # noqa: BLE001 - BadPinFactory, GPIOPinInUse, ...
            pin = self.coil_pins[len(self._coils)]
            self.close()
            raise BackendError(f"error: gpiozero cannot drive GPIO{pin} ({type(e).__name__}: "
                               f"{e}); {HINT}") from None
        if self.cfg.pen.kind != "servo":
            self._open_pen()
            return
        try:
            factory = self._coils[0].pin_factory
            if _lgpio_of(factory) is not None:
                self._lgpio_pen(factory)
            else:
                self._servo = self._make_servo(factory)
        except Exception as e:  # noqa: BLE001
            self.close()
            raise BackendError(f"error: gpiozero cannot make servo pulses on GPIO{self.pen_pin} "
                               f"({type(e).__name__}: {e}); use a pin factory with PWM "
                               f"(lgpio, pigpio, RPi.GPIO) or --dry-run") from None

    def _open_pen(self) -> None:
        """The pen pin as a plain output (and the cam's switch as an input)."""
        from gpiozero import DigitalInputDevice, DigitalOutputDevice

        from vplotter.backends import pens

        pen, factory = self.cfg.pen, self._coils[0].pin_factory
        try:
            out = DigitalOutputDevice(self.pen_pin, initial_value=False, pin_factory=factory)
            self._pen_devices.append(out)
            switch = None
            if pen.kind == "switch":
                switch = DigitalInputDevice(pen.switch_pin, pull_up=pen.switch_active_low,
                                            pin_factory=factory)
                self._pen_devices.append(switch)
        except Exception as e:  # noqa: BLE001
            self.close()
            raise BackendError(f"error: gpiozero cannot use the pen's pins ({type(e).__name__}: "
                               f"{e}); {HINT}") from None
        self._kind_pen = pens.create(self.cfg, lambda level: setattr(out, "value", level),
                                     lambda: bool(switch.pin.state))

    def read_input(self, pin: int) -> bool:
        from gpiozero import DigitalInputDevice

        dev = DigitalInputDevice(pin, pull_up=True, pin_factory=self._coils[0].pin_factory)
        try:
            return bool(dev.pin.state)
        finally:
            dev.close()

    def _prepare_lgpio(self):
        """When gpiozero may pick its lgpio factory: import lgpio safely first (its notify
        FIFO in the state directory, not in the working directory) and tight timers. Without
        lgpio gpiozero picks another factory."""
        wanted = os.environ.get("GPIOZERO_PIN_FACTORY", "").lower()
        if self.pin_factory is None and wanted in ("", "lgpio"):
            from vplotter.backends.lgpio_setup import load_lgpio, tight_timers

            try:
                load_lgpio()
            except BackendError:
                return contextlib.nullcontext()
            tight_timers()
        return contextlib.nullcontext()

    def _lgpio_pen(self, factory) -> None:
        from gpiozero import DigitalOutputDevice

        for w in servo_widths(self.cfg):
            if not 500 <= w <= 2500:
                raise ValueError(f"lgpio makes servo pulses of 500..2500 us, not {w} ([pen] "
                                 f"up_us/down_us)")
        self._pen_dev = DigitalOutputDevice(self.pen_pin, initial_value=False,
                                            pin_factory=factory)
        lg, handle, pin = _lgpio_of(factory), factory._handle, self.pen_pin
        self._player.pulse = lambda level: lg.gpio_write(handle, pin, level)

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
        """Motor outputs at the idle word (coils low, ENABLE high), pen pulses off (a pulse the
        player writes is always whole when play() returns), pins released; never raises."""
        self._idle()
        for dev in self._pen_devices:
            for action in (getattr(dev, "off", lambda: None), dev.close):
                try:
                    action()
                except Exception:  # noqa: BLE001
                    pass
        self._pen_devices, self._kind_pen = [], None
        if self._pen_dev is not None:
            self._player.pulse = None
            for action in (self._pen_dev.off, self._pen_dev.close):
                try:
                    action()
                except Exception:  # noqa: BLE001
                    pass
            self._pen_dev = None
        if self._servo is not None:
            for action in (self._servo.detach, self._servo.close):
                try:
                    action()
                except Exception:  # noqa: BLE001
                    pass
            self._servo = None
        self._idle()
        for dev in self._coils:
            try:
                dev.close()
            except Exception:  # noqa: BLE001
                pass
        self._coils = []

    def _idle(self) -> None:
        """The motor outputs at the idle word: coils low, or ENABLE high (motors free)."""
        for bit, dev in enumerate(self._coils):
            try:
                dev.value = self.idle_word >> bit & 1
            except Exception:  # noqa: BLE001
                pass

    def lateness(self) -> dict | None:
        return self._player.lateness.stats()


def _lgpio_of(factory):
    """The lgpio module behind gpiozero's lgpio factory, or None for any other factory."""
    if type(factory).__name__ != "LGPIOFactory":
        return None
    return getattr(sys.modules.get(type(factory).__module__), "lgpio", None)


def _mock_without_pwm(factory):
    """gpiozero's MockFactory makes pins without PWM unless told otherwise: return the PWM
    mock pin class to use for the pen, or None for any other factory."""
    if type(factory).__name__ != "MockFactory":
        return None
    from gpiozero.pins.mock import MockPWMPin

    return None if issubclass(factory.pin_class, MockPWMPin) else MockPWMPin
