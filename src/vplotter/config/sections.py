"""One frozen dataclass per section of config.toml (what the rest of vplotter reads)."""

from __future__ import annotations

from dataclasses import dataclass

from vplotter.inputs.gcode import PenDialect as Gcode   # [gcode]: how files move the pen

DRIVES = ("half", "full", "wave")
KINDS = ("vplotter", "polar")
DRIVERS = ("uln2003", "stepdir")
PEN_KINDS = ("servo", "switch", "output")
UNSET = "unset"   # a default: the key may be left out (the value is then None)
MOTOR_NAMES = {"vplotter": ("left", "right"), "polar": ("rotary", "linear")}


@dataclass(frozen=True)
class Machine:
    anchor_distance_mm: float | None = None
    kind: str = "vplotter"


@dataclass(frozen=True)
class Polar:
    """The polar plotter: a rotary table under a linear arm (G-code frame, mm and degrees)."""

    centre_x_mm: float
    centre_y_mm: float
    arm_angle_deg: float
    radius_min_mm: float
    radius_max_mm: float
    home_pin: int | None
    home_radius_mm: float | None
    home_active_low: bool


@dataclass(frozen=True)
class Origin:
    x_mm: float
    y_mm: float


@dataclass(frozen=True)
class Page:
    x_min_mm: float
    x_max_mm: float
    y_min_mm: float
    y_max_mm: float


@dataclass(frozen=True)
class Motors:
    drive: str
    steps_per_rev: int
    spool_circumference_mm: float
    max_step_rate: float
    max_accel: float
    left_pins: tuple[int, int, int, int]
    right_pins: tuple[int, int, int, int]
    left_reverse: bool
    right_reverse: bool
    # which keys apply depends on [machine] kind and [motors] driver; the others stay None
    driver: str = "uln2003"
    names: tuple[str, str] = ("left", "right")
    rotary_steps_per_deg: float | None = None
    linear_steps_per_mm: float | None = None
    rotary_pins: tuple[int, int, int, int] | None = None
    linear_pins: tuple[int, int, int, int] | None = None
    rotary_reverse: bool = False
    linear_reverse: bool = False
    left_step_pin: int | None = None
    left_dir_pin: int | None = None
    right_step_pin: int | None = None
    right_dir_pin: int | None = None
    rotary_step_pin: int | None = None
    rotary_dir_pin: int | None = None
    linear_step_pin: int | None = None
    linear_dir_pin: int | None = None
    enable_pin: int | None = None
    dir_setup_us: int = 1
    step_pulse_us: int = 2

    left_spool_circumference_mm: float | None = None    # None: spool_circumference_mm
    right_spool_circumference_mm: float | None = None

    @property
    def circumferences_mm(self) -> tuple[float, float]:
        """Cord wound per spool turn, left and right (V-plotter)."""
        return (self.left_spool_circumference_mm or self.spool_circumference_mm,
                self.right_spool_circumference_mm or self.spool_circumference_mm)

    @property
    def steps_per_unit(self) -> tuple[float, float]:
        """Steps per unit of each motor's coordinate: per mm of cord (left, right), or per
        degree of the table and per mm of the arm (rotary, linear)."""
        if self.names[0] == "rotary":
            return (self.rotary_steps_per_deg, self.linear_steps_per_mm)
        left, right = self.circumferences_mm
        return (self.steps_per_rev / left, self.steps_per_rev / right)

    def _pair(self, suffix: str) -> tuple:
        return tuple(getattr(self, f"{n}_{suffix}") for n in self.names)

    @property
    def reverse(self) -> tuple[bool, bool]:
        return self._pair("reverse")

    @property
    def out_pins(self) -> list[int]:
        """The motor output pins, bit i of an output word = out_pins[i]: IN1..IN4 of both
        motors (uln2003), or STEP, DIR of both motors and ENABLE (stepdir)."""
        if self.driver == "stepdir":
            pins = [getattr(self, f"{n}_{what}_pin")
                    for n in self.names for what in ("step", "dir")]
            return pins + [self.enable_pin]
        return [p for pins in self._pair("pins") for p in pins]

    @property
    def idle_word(self) -> int:
        """The output word of released motors: coils all low, or ENABLE high (drivers off)."""
        return 1 << 4 if self.driver == "stepdir" else 0


@dataclass(frozen=True)
class Pen:
    """kind "servo": `pin` gets pulses of up_us/down_us. "output": `pin` is held high while
    the pen is down (a solenoid). "switch": `pin` runs the cam motor: up until `switch_pin`
    closes (at most timeout_s), down for down_s. The schedule's pen rows carry up_us/down_us
    for every kind (1 and 2 for output and switch): the backend turns them into what the kind
    needs (backends/pens.py)."""

    pin: int
    up_us: int
    down_us: int
    settle_s: float
    kind: str = "servo"
    switch_pin: int | None = None
    switch_active_low: bool = True
    timeout_s: float = 2.0
    down_s: float = 0.2


@dataclass(frozen=True)
class Motion:
    tolerance_mm: float
    draw_speed_mm_s: float
    travel_speed_mm_s: float


@dataclass(frozen=True)
class Gpio:
    backend: str
    chip: int
    realtime: bool = False      # backend "fake": play in real time (try the page on a computer)


@dataclass(frozen=True)
class Gondola:
    cord_spacing_mm: float     # between the points where the two cords hold the gondola
    pen_below_mm: float        # the pen below the line through those points (midway)
    # the centre of mass below the pen, on the gondola's symmetry line (negative: above);
    # None: the gondola stays level (the plain model)
    mass_below_pen_mm: float | None = None
    mass_g: float | None = None     # the gondola's mass with its pen (the cords' sag needs it)


@dataclass(frozen=True)
class Cords:
    stretch: float             # strain of a cord that alone carries the gondola's weight
    mass_g_per_m: float = 0.0  # the cords' mass per metre (0: they do not sag)

    def sag_per_mm(self, gondola: Gondola) -> float:
        """The cords' mass per mm over the gondola's mass (1/mm): all of the sag's physics;
        0 where the cords have no mass."""
        if not self.mass_g_per_m:
            return 0.0
        return self.mass_g_per_m / 1000.0 / gondola.mass_g


@dataclass(frozen=True)
class Serial:
    port: str
    baud: int
    rx_buffer: int
    pen_down: str
    pen_up: str
    axes: str
    feed_scale: float
    timeout_s: float


@dataclass(frozen=True)
class PenSpec:
    """A pen the person owns ([pens.NAME]): its colour and what it changes when it is in."""

    name: str
    colour: str                      # '#rrggbb'
    width_mm: float | None = None    # the line it draws (default: the tone model's --pen-width)
    speed_mm_s: float | None = None  # draw speed cap with this pen (default [motion])
    down_us: int | None = None       # servo pulse for pen down with this pen (default [pen])


@dataclass(frozen=True)
class Pens:
    """[pens]: where the gondola waits at a pen change, and the pens the person owns (none:
    each colour of a file is a pen of its own)."""

    change_x_mm: float | None = None     # default: where the plot started
    change_y_mm: float | None = None
    owned: tuple[PenSpec, ...] = ()

    @property
    def change_at(self) -> tuple[float, float] | None:
        if self.change_x_mm is None or self.change_y_mm is None:
            return None
        return (self.change_x_mm, self.change_y_mm)

    def get(self, name: str) -> PenSpec | None:
        return next((p for p in self.owned if p.name == name), None)


@dataclass(frozen=True)
class Notify:
    """[notify]: where a draw's ends, pauses, failures and pen-change waits are POSTed."""

    url: str | None = None           # None: no notifications
    timeout_s: float = 5.0


@dataclass(frozen=True)
class Config:
    machine: Machine
    origin: Origin
    page: Page
    motors: Motors
    pen: Pen
    motion: Motion
    gpio: Gpio
    gondola: Gondola = Gondola(0.0, 0.0)
    cords: Cords = Cords(0.0)
    serial: Serial | None = None
    gcode: Gcode = Gcode()
    path: str = "config.toml"
    polar: Polar | None = None
    pens: Pens = Pens()
    notify: Notify = Notify()


# section -> key -> (kind, default or None if required, low, high[, when]); bounds are inclusive
# unless the kind ends in '+' (strictly above low). `when` names the machine kind, driver or pen
# kind ("polar", "stepdir", "vplotter uln2003", ...) a key belongs to: elsewhere it is an error.
