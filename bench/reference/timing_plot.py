"""Plot the step rate of both motors over time from a GPIO trace v1 (a PNG, Pillow only).

Reads the trace and config.toml only (nothing of vplotter), decodes each motor's coil
patterns into signed steps (half, full or wave table; + = the cord gets longer, the
`*_reverse` flags applied), counts them in windows of --window seconds and draws steps/s of
the left and the right motor against time, the limit +-max_step_rate as dashed lines and the
pen-down time shaded. The picture in docs/timing.md was made with:

    vplotter draw gcode_samples/car.ngc --dry-run --trace /tmp/car.csv
    python -m bench.reference.timing_plot /tmp/car.csv config.toml -o docs/img/timing-car.png \
        --start 0 --seconds 120
"""

from __future__ import annotations

import argparse
import tomllib

import numpy as np
from PIL import Image, ImageDraw, ImageFont

TABLES = {   # bit 0 = IN1 ... bit 3 = IN4; "forward" walks the table upwards
    "half": [0b0001, 0b0011, 0b0010, 0b0110, 0b0100, 0b1100, 0b1000, 0b1001],
    "full": [0b0011, 0b0110, 0b1100, 0b1001],
    "wave": [0b0001, 0b0010, 0b0100, 0b1000],
}
LEFT, RIGHT, LIMIT, PEN = (200, 40, 40), (30, 90, 200), (150, 150, 150), (236, 240, 228)


def read_trace(path: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rows = np.loadtxt(path, delimiter=",", comments="#", skiprows=2, ndmin=2)
    return rows[:, 0], rows[:, 1].astype(int), rows[:, 2].astype(int)


def motor_steps(t, pin, val, pins, table, reverse):
    """(times, +-1) of each step of one motor: the pattern after all rows of one time."""
    sel = np.isin(pin, pins)
    tt, pp, vv = t[sel], pin[sel], val[sel]
    bit = {p: i for i, p in enumerate(pins)}
    phase = {pat: i for i, pat in enumerate(table)}
    n = len(table)
    word, last, times, signs = 0, None, [], []
    for i in range(len(tt)):
        b = 1 << bit[pp[i]]
        word = word | b if vv[i] else word & ~b
        if i + 1 < len(tt) and tt[i + 1] == tt[i]:
            continue                      # rows with equal t take effect together
        ph = phase.get(word)
        if ph is None:                    # released (0) or not in the table: no step
            last = None if word == 0 else last
            continue
        if last is not None and ph != last:
            d = (ph - last) % n
            d = d - n if d > n // 2 else d
            times.append(tt[i])
            signs.append(-d if reverse else d)
        last = ph
    return np.array(times), np.array(signs, dtype=float)


def pen_down(t, pin, val, pen_pin, down_us):
    """(start, end) of the stretches where the last pulse width other than 0 is down_us."""
    sel = (pin == pen_pin) & (val != 0)
    spans, start = [], None
    for ti, v in zip(t[sel], val[sel]):
        if v == down_us and start is None:
            start = ti
        elif v != down_us and start is not None:
            spans.append((start, ti))
            start = None
    if start is not None:
        spans.append((start, t[-1]))
    return spans


def legend(d, font, x, top, k, rate) -> None:
    """The legend above the plot, from x to the right."""
    for label, colour in (("left motor", LEFT), ("right motor", RIGHT),
                          (f"limit +-{rate:g}", LIMIT), ("pen down", PEN)):
        if colour == PEN:
            d.rectangle([x, top - 20 * k, x + 22 * k, top - 8 * k], fill=PEN,
                        outline=(180, 180, 180))
        else:
            d.line([x, top - 14 * k, x + 22 * k, top - 14 * k], fill=colour, width=3 * k)
        d.text((x + 28 * k, top - 14 * k), label, fill="black", font=font, anchor="lm")
        x += (len(label) * 7 + 50) * k


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("trace")
    ap.add_argument("config")
    ap.add_argument("-o", "--output", default="timing.png")
    ap.add_argument("--start", type=float, default=0.0, help="first second shown")
    ap.add_argument("--seconds", type=float, default=120.0, help="how many seconds")
    ap.add_argument("--window", type=float, default=0.25, help="counting window (s)")
    ap.add_argument("--width", type=int, default=900)
    ap.add_argument("--height", type=int, default=420)
    a = ap.parse_args()

    cfg = tomllib.load(open(a.config, "rb"))
    m = cfg["motors"]
    table = TABLES[m.get("drive", "half")]
    rate = float(m["max_step_rate"])
    t, pin, val = read_trace(a.trace)
    t0, t1 = a.start, a.start + a.seconds
    edges = np.arange(t0, t1 + a.window / 2, a.window)
    series = []
    for name, colour in (("left", LEFT), ("right", RIGHT)):
        st, sg = motor_steps(t, pin, val, m[f"{name}_pins"], table, m.get(f"{name}_reverse", False))
        counts, _ = np.histogram(st, bins=edges, weights=sg)
        series.append((name, colour, counts / a.window))
    pen = cfg["pen"]
    spans = pen_down(t, pin, val, pen["pin"], pen.get("down_us", 2))

    W, H, k = a.width, a.height, 2                 # drawn at 2x, then downsampled
    img = Image.new("RGB", (W * k, H * k), "white")
    d = ImageDraw.Draw(img)
    try:
        font = ImageFont.load_default(size=13 * k)
    except (TypeError, AttributeError, OSError):
        font = ImageFont.load_default()
    left, right, top, bottom = 70 * k, 20 * k, 40 * k, 50 * k
    pw, ph = W * k - left - right, H * k - top - bottom
    ymax = rate * 1.15

    def X(s):
        return left + (s - t0) / (t1 - t0) * pw

    def Y(v):
        return top + (ymax - v) / (2 * ymax) * ph

    for s0, s1 in spans:                           # pen down: shaded
        if s1 > t0 and s0 < t1:
            d.rectangle([X(max(s0, t0)), top, X(min(s1, t1)), top + ph], fill=PEN)
    d.rectangle([left, top, left + pw, top + ph], outline=(0, 0, 0), width=k)
    for v in (rate, -rate):                        # the limit, dashed
        x = left
        while x < left + pw:
            d.line([x, Y(v), min(x + 8 * k, left + pw), Y(v)], fill=LIMIT, width=k)
            x += 14 * k
    d.line([left, Y(0), left + pw, Y(0)], fill=(200, 200, 200), width=k)
    step_v = 200 if rate < 1500 else 1000
    for v in np.arange(-step_v * (rate // step_v), rate + 1, step_v):
        d.text((left - 6 * k, Y(v)), f"{v:.0f}", fill="black", font=font, anchor="rm")
    step_t = max(1, round((t1 - t0) / 8 / 5) * 5)
    for s in np.arange(np.ceil(t0 / step_t) * step_t, t1 + 1e-9, step_t):
        d.line([X(s), top + ph, X(s), top + ph + 4 * k], fill="black", width=k)
        d.text((X(s), top + ph + 6 * k), f"{s:.0f}", fill="black", font=font, anchor="mt")
    d.text((left + pw / 2, H * k - 8 * k), "time (s)", fill="black", font=font, anchor="ms")
    d.text((8 * k, top - 12 * k), "steps/s (+: cord longer)", fill="black", font=font, anchor="ls")
    centres = (edges[:-1] + edges[1:]) / 2
    for name, colour, r in series:
        pts = [(X(c), Y(v)) for c, v in zip(centres, r)]
        d.line(pts, fill=colour, width=2 * k, joint="curve")
    legend(d, font, left + 230 * k, top, k, rate)
    img = img.resize((W, H), getattr(Image, "Resampling", Image).LANCZOS)
    img.save(a.output, optimize=True)
    peak = max(float(np.abs(r).max()) for _, _, r in series)
    print(f"{a.output}: {W} x {H} px, {t0:g}..{t1:g} s, highest {a.window:g} s-window rate "
          f"{peak:.0f} steps/s (limit {rate:g})")


if __name__ == "__main__":
    main()
