"""lgpio backend: the coils as one lgpio group and the pen's servo pulses, all written by
vplotter's own player (`realtime.Player`); lgpio's tx thread is never given a job.

Why not lgpio's waves (tx_wave): lgpio's tx thread is software-timed against a timeline of its
own that never looks at the clock again. When it is late (the process was stopped, the SD card
stalled the system, another thread took the CPU) it plays every late pulse back to back until
that timeline has caught up: hundreds of steps 15-30 us apart after a 0.3 s stall, which a
28BYJ-48 cannot follow. It also keeps the pulse buffer of every wave that finished with another
queued behind it (24 bytes per pulse, never freed). So the coil timeline is vplotter's: all eight
coil pins are one lgpio group, and `realtime.Player` writes each change with one `group_write`
(both motors change in one write) at its time; a late change shifts the rest of the timeline
instead of being caught up.

The pen: lgpio's servo trains (tx_servo, tx_pulse) are timed by the same tx thread, which sleeps
between edges: on the virtual machine measured here a rise after its 19 ms sleep came ~50 us
later than a fall after its short one, and even with a wake-up entry before every rise one pulse
in ten to forty was more than 20 us off (one in a hundred by milliseconds). Freeing a train's job
while another is queued is also what hangs lgpio 0.2's thread. So the player writes the pen pin
itself (gpio_write), spinning through each pulse from rise to fall: exact to the microsecond, and
nothing is left in lgpio that could hang.

lgpio is imported lazily and safely by `lgpio_setup.load_lgpio()` (notify FIFO in the state
directory, working directory unchanged); every failure is one line that says what to do.
"""

from __future__ import annotations

import inspect
import time


from vplotter.backends.base import Backend, servo_widths
from vplotter.backends.lgpio_setup import chip_error, load_lgpio, tight_timers
from vplotter.backends import memory
from vplotter.backends.realtime import Player
from vplotter.errors import BackendError
from vplotter.motion.schedule import Rows


class LgpioBackend(Backend):
    name = "lgpio"

    def __init__(self, cfg, realtime: bool = True, lgpio=None, clock=None, sleep=None,
                 **timing):
        """lgpio: the lgpio module (default: `load_lgpio()`); clock() -> ns, sleep(s) and the
        timing options (spin_us, poll_us, ...) go to `realtime.Player`; realtime is accepted and
        ignored (this backend always plays in real time)."""
        super().__init__(cfg)
        self.chip = cfg.gpio.chip
        self.leader = self.coil_pins[0]
        self.mask = (1 << len(self.coil_pins)) - 1
        self.lg = lgpio
        self.clock = clock or time.perf_counter_ns
        self.sleep = sleep or time.sleep
        self.handle: int | None = None
        if "min_step_us" in inspect.signature(Player).parameters and cfg.motors.driver == "uln2003":
            timing = {"min_step_us": 1e6 / cfg.motors.max_step_rate, **timing}   # coils only
        self._player = Player(self._write_coils, None, self.clock, self.sleep,
                              pulse=self._write_pen, **timing)
        self._player.coils = self.idle_word

    # ------------------------------------------------------------ open / close
    def open(self) -> None:
        if self.cfg.pen.kind != "servo":
            raise BackendError(f"error: the lgpio backend drives a servo pen; for [pen] kind = "
                               f"\"{self.cfg.pen.kind}\" use --backend gpiozero")
        for w in servo_widths(self.cfg):
            if not 500 <= w <= 2500:
                raise BackendError(f"error: servo pulses are 500..2500 us, not {w} "
                                   f"([pen] up_us/down_us)")
        lg = self.lg = self.lg or load_lgpio()
        tight_timers()
        memory.lean_malloc()
        try:
            h = lg.gpiochip_open(self.chip)
        except lg.error as e:
            raise chip_error(self.chip, str(e)) from None
        if h < 0:
            raise chip_error(self.chip, f"error code {h}")
        self.handle = h
        try:
            idle = [self.idle_word >> b & 1 for b in range(len(self.coil_pins))]
            lg.group_claim_output(h, list(self.coil_pins), idle)
            lg.gpio_claim_output(h, self.pen_pin, 0)
        except lg.error as e:
            self.close()
            raise BackendError(f"error: cannot claim GPIO {list(self.coil_pins)} and "
                               f"{self.pen_pin} on gpiochip{self.chip} ({e}); is another program "
                               f"using them? (or change the pins in the config)") from None

    def close(self) -> None:
        """All coils low, the pen pin low (a pulse is always whole when play() returns), pins and
        chip released. Never raises."""
        lg, h = self.lg, self.handle
        if h is None:
            return
        steps = [lambda: lg.group_write(h, self.leader, self.idle_word, self.mask),
                 lambda: lg.gpio_write(h, self.pen_pin, 0),
                  lambda: lg.group_free(h, self.leader),
                  lambda: lg.gpio_free(h, self.pen_pin),
                  lambda: lg.gpiochip_close(h)]
        for step in steps:
            try:
                step()
            except BaseException:  # noqa: BLE001 - an error or a second Ctrl+C: go on releasing
                pass
        self.handle = None

    def lateness(self) -> dict | None:
        return self._player.lateness.stats()

    # ------------------------------------------------------------ play
    def play(self, rows: Rows) -> int:
        """Every change is written when this returns (drain() has nothing to wait for)."""
        if len(rows) == 0 or self.stop_requested or self.handle is None:
            return 0
        try:
            return self._player.play(rows, lambda: self.stop_requested)
        except self.lg.error as e:
            raise BackendError(f"error: lgpio failed while drawing: {e}") from None

    def _write_coils(self, word: int, changed: int) -> None:
        self.lg.group_write(self.handle, self.leader, word, self.mask)

    def _write_pen(self, level: int) -> None:
        self.lg.gpio_write(self.handle, self.pen_pin, level)

    def read_input(self, pin: int) -> bool:
        lg, h = self.lg, self.handle
        lg.gpio_claim_input(h, pin, lg.SET_PULL_UP)
        try:
            return bool(lg.gpio_read(h, pin))
        finally:
            lg.gpio_free(h, pin)
