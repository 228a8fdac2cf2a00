"""Tone fidelity of the photo styles against `hatched` (the vpype plugin) at the same drawn length.

For every image in a folder, every style (hatch, spiral, squiggle, stipple) and the budgets
1 h and 3 h, 300 mm wide on the machine of ./config.toml:

- ours: `vplotter convert IMAGE -o OUT.ngc --style S --width 300 --max-time B` (the installed
  CLI, a subprocess); the G-code is read back by the independent reader of the tests
  (`tracecheck.reference_path`: pen-down polylines, 1-point ones are dots);
- hatched: `hatched.hatch(grey.png, hatch_pitch=P, levels=(64, 128, 192), blur_radius=10,
  image_scale=1, save_svg=False, show_plot=False)` in its own venv (`--hatched-python`,
  default /tmp/venv-hatched/bin/python; it pulls OpenCV, never installed beside vplotter), run
  by this file as a worker (`--hatched-worker`) that keeps the picture loaded. It is given the
  picture upright (EXIF applied), 8-bit grey, HATCHED_PX pixels across (its defaults were made
  for pictures of about that size) and its lines are scaled to the same 300 mm. Its pitch is
  searched (secant on log length against log pitch, every try kept) until its drawn length is
  within TOL of ours. A stipple drawing has no length (dots): there hatched gets the drawn
  length whose plot time (`vplotter estimate --order best` of its lines as G-code, the same
  planner) equals that of our dots.
- metric, the same for both: the strokes are drawn as lines of the pen width (0.5 mm; dots as
  discs) at RASTER px/mm (`stamp`: exact at every angle, unlike Pillow's wide lines), reduced to ink coverage 0..1 per 0.5 mm cell (box),
  and Gaussian-blurred with sigma 1 mm (viewing distance); the photo's darkness is computed
  here, independently of vplotter (Pillow's ImageOps.exif_transpose, sRGB decoded,
  Y = 0.2126 R + 0.7152 G + 0.0722 B, darkness 1 - Y), box-resized in linear light to the same
  cells and blurred the same way. Figures: Pearson correlation of ink with darkness over the
  picture, SSIM (Wang et al., Gaussian window sigma 1.5 cells, data range 1: at plotter ink
  levels it mostly measures the amount of ink), and the mean ink against the mean darkness.
- a picture whose name starts with "ramp" (a grey ramp, dark to the right) is also cut into 5
  bands across: the ink per area in each band must rise with darkness, in every style.

Style "tsp" is `--style stipple --tsp` (TSP art: a line, compared at the same drawn length).
Style "stipple" with a budget is the better of its dots and its tour (the converter chooses).
Style "auto" is `--style auto`: its own file is measured like any other, and set against the
best of the other styles run (give them all: `--styles hatch,spiral,squiggle,stipple,flow,auto`)
by the bench's measure; without it, the style with the best own score is listed instead.

At the same plot time: every drawing is also compared with `hatched` at the pitch whose lines,
put in a nearest-neighbour order (`vplotter estimate --order greedy`: the draw's own planner),
take our drawing's plot time (`h@time`, `diff` = ours - hatched's correlation). `own`: the
converter's own score of our file (`inputs/image/score.py`, 1 mm cells); per picture and
budget the style `--style auto` kept (style "auto" run), or the style with the best own score,
is printed beside the best style by the bench's measure.

Output: per image a table (style, budget, drawn m, our plot time, ours corr, hatched corr at the
same length, ratio, SSIM both, mean ink both, hatched pitch and plot time), then the smallest
ratio per style over the photographs (names starting with "photo"; line art and the ramp are
listed apart).

Test pictures (nothing downloaded: scikit-image bundles its sample photographs; run with a
python that has it, e.g. a throwaway venv, and keep them out of the repo):
    /tmp/venv-skimage/bin/python -m bench.photo_tone --make /tmp/photos
Run (from the repository root, in vplotter's venv):
    python -m bench.photo_tone /tmp/photos [--budgets 1h,3h] [--styles hatch,spiral,tsp]
        [--hatched-python /tmp/venv-hatched/bin/python] [--keep DIR] [--jobs 2]
"""

from __future__ import annotations

import argparse
import io
import json
import math
import os
import re
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np

# the repository's root; not `from bench import ROOT`: the --hatched-worker runs this file by its
# path in hatched's own venv, where neither bench nor vplotter is importable
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
WIDTH_MM, PEN_MM = 300.0, 0.5
RASTER = 10            # px/mm of the line rendering
CELL = 5               # raster px per analysis cell (0.5 mm)
SIGMA_MM = 1.0         # viewing-distance blur
HATCHED_PX = 1000      # hatched's picture: pixels across
TOL = 0.02             # drawn length (or plot time) within 2 % of ours
STYLES = ("hatch", "spiral", "squiggle", "stipple", "flow")
SUFFIXES = (".png", ".jpg", ".jpeg", ".webp", ".bmp", ".tif", ".tiff", ".gif")


# ---------------------------------------------------------------- test pictures
def make(folder: str) -> None:
    """Photographs bundled with scikit-image, a line drawing, a grey ramp and a large phone
    photo (12 MP JPEG stored on its side, EXIF orientation 6)."""
    from PIL import Image, ImageDraw, ImageFilter, ImageFont
    from skimage import data

    os.makedirs(folder, exist_ok=True)
    photos = {"photo-cat": data.chelsea(), "photo-astronaut": data.astronaut(),
              "photo-coffee": data.coffee(), "photo-camera": data.camera(),
              "photo-rocket": data.rocket()}
    for name, a in photos.items():
        Image.fromarray(a).save(os.path.join(folder, name + ".png"))
    # a phone photo: the coffee cup at 4032 x 3024, sensor noise, stored portrait-on-its-side
    cup = Image.fromarray(data.coffee()).crop((33, 0, 567, 400)).resize((4032, 3024),
                                                                        Image.Resampling.BICUBIC)
    rng = np.random.default_rng(1)
    a = np.asarray(cup, dtype=np.float32) + rng.normal(0, 4, (3024, 4032, 1)).astype(np.float32)
    cup = Image.fromarray(np.clip(a, 0, 255).astype(np.uint8)).transpose(Image.Transpose.ROTATE_90)
    exif = Image.Exif()
    exif[0x0112] = 6                  # shown rotated 90 degrees clockwise: upright again
    cup.save(os.path.join(folder, "photo-phone-12mp.jpg"), quality=88, exif=exif)
    # line art: black strokes on white
    w, h = 1200, 900
    im = Image.new("L", (w, h), 255)
    d = ImageDraw.Draw(im)
    d.polygon([(150, 500), (450, 250), (750, 500)], outline=0, width=8)
    d.rectangle([200, 500, 700, 820], outline=0, width=8)
    d.rectangle([400, 640, 500, 820], outline=0, width=6)
    for k in range(6):
        d.ellipse([880 - 30 * k, 150 - 30 * k, 1000 + 30 * k, 270 + 30 * k], outline=0, width=4)
    for k in range(12):
        d.line([(60, 60 + 20 * k), (60 + 40 * k, 60)], fill=0, width=3)
    d.line([(800, 820), (1150, 560)], fill=0, width=12)
    d.text((780, 860 - 120), "line art", fill=0, font=ImageFont.load_default(size=70))
    im.filter(ImageFilter.GaussianBlur(0.7)).save(os.path.join(folder, "lineart.png"))
    # grey ramp: white (left) to black (right), even steps of the sRGB value
    ramp = np.tile(np.linspace(255, 0, 1200), (600, 1)).astype(np.uint8)
    Image.fromarray(ramp).save(os.path.join(folder, "ramp.png"))


# ---------------------------------------------------------------- hatched worker
def hatched_worker() -> None:
    """In hatched's venv: lines on stdin requests {"image", "pitch", "out"} -> writes the
    lines (pixel coordinates, y down) to out (.npz), answers {"length_px", "lines"}."""
    import contextlib

    import hatched.hatched as hh
    import shapely.geometry as sg

    # hatched 0.2.0 was written for Shapely 1: under Shapely 2 (all pip gives with NumPy 2)
    # MultiLineString() no longer takes an empty array or a collection, and a level that no
    # pixel is lighter than has no mask (None, which Shapely 2 propagates). Same algorithm:
    mls_class = sg.MultiLineString

    def multilinestring(lines=None):
        if isinstance(lines, np.ndarray) and lines.size == 0:
            return mls_class()
        if isinstance(lines, sg.base.BaseGeometry) and not isinstance(lines, mls_class):
            parts = []
            for g in getattr(lines, "geoms", [lines]):
                if g.geom_type == "LineString" and not g.is_empty:
                    parts.append(g)
                elif g.geom_type == "MultiLineString":
                    parts.extend(g.geoms)
            return mls_class(parts)
        return mls_class(lines)

    build_mask = hh._build_mask
    hh.MultiLineString = multilinestring
    hh._build_mask = lambda cnt: (lambda m: sg.Polygon() if m is None else m)(build_mask(cnt))

    for req in sys.stdin:
        q = json.loads(req)
        said = io.StringIO()
        with contextlib.redirect_stdout(said):       # hatched prints its errors
            mls = hh.hatch(q["image"], hatch_pitch=q["pitch"], levels=(64, 128, 192),
                            blur_radius=10, image_scale=1.0, save_svg=False, show_plot=False)
        lines = [np.asarray(ls.coords, dtype=np.float64) for ls in mls.geoms]
        lines = [p for p in lines if len(p) >= 2]
        np.savez(q["out"], *lines)
        length = float(sum(np.hypot(*np.diff(p, axis=0).T).sum() for p in lines))
        print(json.dumps({"length_px": length, "lines": len(lines), "said": said.getvalue()}),
              flush=True)


class Hatched:
    """hatched.hatch through the worker, for one picture; every try cached."""

    def __init__(self, python: str, photo: str, tmp: str):
        from PIL import Image, ImageOps

        im = ImageOps.exif_transpose(Image.open(photo)).convert("L")
        hh = round(HATCHED_PX * im.height / im.width)
        self.grey = os.path.join(tmp, "hatched-" + os.path.splitext(os.path.basename(photo))[0]
                                 + ".png")
        im.resize((HATCHED_PX, hh), Image.Resampling.LANCZOS).save(self.grey)
        self.mm_per_px = WIDTH_MM / HATCHED_PX
        self.tmp = tmp
        self.tries: dict[float, tuple[float, str]] = {}
        self.proc = subprocess.Popen([python, os.path.abspath(__file__), "--hatched-worker"],
                                     stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)

    def close(self):
        self.proc.stdin.close()
        self.proc.wait()

    def run(self, pitch_mm: float) -> tuple[float, str]:
        """(drawn m, npz path) at this pitch."""
        pitch_mm = float(f"{pitch_mm:.6g}")
        if pitch_mm not in self.tries:
            out = os.path.join(self.tmp, f"h{len(self.tries)}-{os.path.basename(self.grey)}.npz")
            self.proc.stdin.write(json.dumps({"image": self.grey, "pitch": pitch_mm / self.mm_per_px,
                                              "out": out}) + "\n")
            self.proc.stdin.flush()
            r = json.loads(self.proc.stdout.readline())
            if r["said"].strip():
                raise RuntimeError(f"hatched: {r['said'].strip()}")
            self.tries[pitch_mm] = (r["length_px"] * self.mm_per_px / 1000, out)
        return self.tries[pitch_mm]

    def lines(self, npz: str) -> list[np.ndarray]:
        """Polylines in picture mm (x right, y down)."""
        with np.load(npz) as z:
            return [z[k] * self.mm_per_px for k in z.files]

    def match(self, target: float, measure) -> tuple[float, float]:
        """(pitch, value) with measure(pitch) within TOL of target; measure rises as the pitch
        falls (about as 1/pitch). Secant in log-log, bracketed."""
        p = 2.0
        seen: list[tuple[float, float]] = []
        for _ in range(14):
            v = measure(p)
            seen.append((p, v))
            if v > 0 and abs(v / target - 1) <= TOL:
                return p, v
            lo = [s for s in seen if s[1] < target]        # too little: pitch too wide
            hi = [s for s in seen if s[1] > target]
            if lo and hi:
                (p0, v0), (p1, v1) = min(lo), max(hi)
                if v0 > 0 and v1 > v0 and p0 != p1:
                    k = math.log(v1 / v0) / math.log(p1 / p0)
                    g = p0 * (target / v0) ** (1 / k)
                else:
                    g = math.sqrt(p0 * p1)
                g = g if min(p0, p1) < g < max(p0, p1) else math.sqrt(p0 * p1)
                if abs(math.log(g / p)) < 1e-4:
                    g = math.sqrt(p0 * p1)
            else:
                g = p * (v / target if v > 0 else 0.25)
            p = min(max(g, 0.05), 200.0)
        return min(seen, key=lambda s: abs(math.log(max(s[1], 1e-9) / target)))


# ---------------------------------------------------------------- ours
def machine_page(config: str) -> tuple[float, float]:
    """Where vplotter centres a photo in G-code mm: X0 Y0 (`place.origin`), or the page's
    centre when X0 Y0 is off the page."""
    import tomllib

    with open(config, "rb") as f:
        page = tomllib.load(f)["page"]
    if page["x_min_mm"] <= 0 <= page["x_max_mm"] and page["y_min_mm"] <= 0 <= page["y_max_mm"]:
        return 0.0, 0.0
    return (page["x_min_mm"] + page["x_max_mm"]) / 2, (page["y_min_mm"] + page["y_max_mm"]) / 2


def vplotter(*args, config: str) -> subprocess.CompletedProcess:
    return subprocess.run(["vplotter", "--config", config, *args], capture_output=True, text=True)


def plot_time(ngc: str, config: str, *extra) -> float:
    r = vplotter("estimate", ngc, *extra, config=config)
    m = re.search(r"plot time [0-9:]+ \(([0-9.]+) s\)", r.stdout + r.stderr)
    if not m:
        raise RuntimeError(f"estimate {ngc}: {(r.stderr or r.stdout).strip()}")
    return float(m.group(1))


def ours(photo: str, style: str, budget: str, out: str, config: str, reuse: bool = False):
    """(pen-down polylines in G-code mm, seconds, spacing note, the style `--style auto` chose
    or None) of vplotter convert (reuse: a file already there is read back, not made again;
    its seconds NaN)."""
    from bench import test_support

    tracecheck = test_support("tracecheck")
    if reuse and os.path.exists(out):
        return tracecheck.reference_path(out, spacing=0.25), float("nan"), None, None
    t0 = time.perf_counter()
    how = ("--style", "stipple", "--tsp") if style == "tsp" else ("--style", style)
    r = vplotter("convert", photo, "-o", out, *how, "--width", f"{WIDTH_MM:g}",
                 "--max-time", budget, config=config)
    wall = time.perf_counter() - t0
    if r.returncode:
        raise RuntimeError(f"convert {photo} {style} {budget}: {r.stderr.strip()}")
    m = re.search(r"spacing ([0-9.]+) mm", r.stderr)
    kept = re.search(r"--style auto chose (\S+(?: --tsp)?) ", r.stderr)
    return (tracecheck.reference_path(out, spacing=0.25), wall, (float(m.group(1)) if m else None),
            kept.group(1) if kept else None)


def to_picture(polys, centre, height_mm):
    """G-code polylines -> picture mm (x right from the left edge, y down from the top)."""
    x0, top = centre[0] - WIDTH_MM / 2, centre[1] + height_mm / 2
    return [np.column_stack([p[:, 0] - x0, top - p[:, 1]]) for p in polys]


def write_gcode(polys_pic, centre, height_mm, path):
    """Picture-mm polylines as Z-pen G-code on the page (as vplotter writes them)."""
    x0, top = centre[0] - WIDTH_MM / 2, centre[1] + height_mm / 2
    with open(path, "w") as f:
        f.write("G21\nG90\nG0 Z5\n")
        for p in polys_pic:
            x, y = p[:, 0] + x0, top - p[:, 1]
            f.write(f"G0 X{x[0]:.4f} Y{y[0]:.4f}\nG1 Z-1\n")
            f.write("".join(f"G1 X{a:.4f} Y{b:.4f}\n" for a, b in zip(x[1:], y[1:])))
            f.write("G0 Z5\n")


def drawn_m(polys) -> float:
    return float(sum(np.hypot(*np.diff(p, axis=0).T).sum() for p in polys if len(p) > 1)) / 1000


# ---------------------------------------------------------------- the metric
def gauss_matrix(n: int, sigma: float) -> np.ndarray:
    """(n, n) matrix of a 1-D Gaussian blur with mirrored edges."""
    r = int(math.ceil(4 * sigma))
    k = np.exp(-0.5 * (np.arange(-r, r + 1) / sigma) ** 2)
    k /= k.sum()
    m = np.zeros((n, n))
    for off, wgt in zip(range(-r, r + 1), k):
        j = np.arange(n) + off
        j = np.where(j < 0, -j - 1, j)
        j = np.where(j >= n, 2 * n - j - 1, j)
        j = np.clip(j, 0, n - 1)
        np.add.at(m, (np.arange(n), j), wgt)
    return m


def blur(a: np.ndarray, sigma_cells: float) -> np.ndarray:
    return gauss_matrix(a.shape[0], sigma_cells) @ a @ gauss_matrix(a.shape[1], sigma_cells).T


def cells(height_mm: float) -> tuple[int, int]:
    """(rows, cols) of the analysis grid."""
    return round(height_mm * RASTER) // CELL, round(WIDTH_MM * RASTER) // CELL


def stamp(polys_px, shape, width_px: float) -> np.ndarray:
    """0/1 raster of the strokes: a pixel is ink where its centre lies within width_px / 2 of
    a stroke (the exact stroke shape with round ends and joins, point-sampled at the pixel
    centres, the same at every angle: Pillow's wide lines come out about 0.7 of their width
    near 45 degrees and 1.07 near 70, which bent the measure by the lines' angles). Each
    polyline is walked in steps of a tenth of the width and a disc set around every step."""
    rows, cols = shape
    r = width_px / 2
    pts = []
    for q in polys_px:
        if len(q) == 1 or np.ptp(q, axis=0).max() < 1e-9:
            pts.append(q[:1])
            continue
        seg = np.hypot(*np.diff(q, axis=0).T)
        n = np.maximum(1, np.ceil(seg / (width_px / 10))).astype(np.int64)
        idx = np.repeat(np.arange(len(seg)), n)
        t = (np.arange(int(n.sum())) - np.repeat(np.cumsum(n) - n, n)) / np.repeat(n, n)
        pts.append(np.vstack([q[idx] + (q[idx + 1] - q[idx]) * t[:, None], q[-1:]]))
    out = np.zeros(rows * cols, dtype=bool)
    if not pts:
        return out.reshape(rows, cols)
    p = np.concatenate(pts)
    base = np.floor(p).astype(np.int64)
    k = int(math.ceil(r)) + 1
    for dy in range(-k, k + 1):
        for dx in range(-k, k + 1):
            cx, cy = base[:, 0] + dx, base[:, 1] + dy
            hit = ((cx + 0.5 - p[:, 0]) ** 2 + (cy + 0.5 - p[:, 1]) ** 2 <= r * r)
            hit &= (cx >= 0) & (cx < cols) & (cy >= 0) & (cy < rows)
            out[cy[hit] * cols + cx[hit]] = True
    return out.reshape(rows, cols)


def ink(polys_pic, height_mm: float) -> np.ndarray:
    """Ink coverage 0..1 per cell, blurred: lines of pen width, dots as discs (`stamp`)."""
    rows, cols = cells(height_mm)
    im = stamp([p * RASTER for p in polys_pic], (rows * CELL, cols * CELL), PEN_MM * RASTER)
    a = im.reshape(rows, CELL, cols, CELL).mean(axis=(1, 3))
    return blur(a, SIGMA_MM * RASTER / CELL)


def darkness(photo: str, height_mm: float) -> np.ndarray:
    """The photo's darkness (linear light) per cell, blurred the same way."""
    from PIL import Image, ImageOps

    im = ImageOps.exif_transpose(Image.open(photo)).convert("RGB")
    v = np.asarray(im, dtype=np.float32) / 255
    lin = np.where(v <= 0.04045, v / 12.92, ((v + 0.055) / 1.055) ** 2.4)
    y = lin @ np.array([0.2126, 0.7152, 0.0722], dtype=np.float32)
    rows, cols = cells(height_mm)
    y = np.asarray(Image.fromarray(y.astype(np.float32), "F").resize((cols, rows),
                                                                     Image.Resampling.BOX))
    return blur(1 - np.clip(y.astype(np.float64), 0, 1), SIGMA_MM * RASTER / CELL)


def ssim(a: np.ndarray, b: np.ndarray) -> float:
    """Mean SSIM (Gaussian window sigma 1.5 cells, data range 1)."""
    c1, c2 = 0.01 ** 2, 0.03 ** 2
    g = lambda x: blur(x, 1.5)        # noqa: E731
    ma, mb = g(a), g(b)
    va, vb, cab = g(a * a) - ma * ma, g(b * b) - mb * mb, g(a * b) - ma * mb
    s = ((2 * ma * mb + c1) * (2 * cab + c2)) / ((ma * ma + mb * mb + c1) * (va + vb + c2))
    return float(s.mean())


def score(ink_a: np.ndarray, dark: np.ndarray) -> dict:
    corr = float(np.corrcoef(ink_a.ravel(), dark.ravel())[0, 1]) if ink_a.std() > 0 else 0.0
    return {"corr": corr, "ssim": ssim(ink_a, dark), "ink": float(ink_a.mean())}


def bands(ink_a: np.ndarray, dark: np.ndarray, n: int = 5):
    """(darkness, ink) per area in n bands across."""
    cut = np.linspace(0, ink_a.shape[1], n + 1).round().astype(int)
    return [(float(dark[:, a:b].mean()), float(ink_a[:, a:b].mean()))
            for a, b in zip(cut[:-1], cut[1:])]


# ---------------------------------------------------------------- the bench
def one_photo(photo, styles, budgets, args, tmp):
    from PIL import Image, ImageOps

    with Image.open(photo) as im:
        w, h = ImageOps.exif_transpose(im).size
    height = WIDTH_MM * h / w
    centre = machine_page(args.config)
    dark = darkness(photo, height)
    hat = Hatched(args.hatched_python, photo, tmp)
    name = os.path.splitext(os.path.basename(photo))[0]
    jobs = [(s, b) for b in budgets for s in styles]

    def convert(job):
        s, b = job
        out = os.path.join(args.keep or tmp, f"{name}.{s}.{b}.ngc")
        polys, wall, spacing, kept = ours(photo, s, b, out, args.config, args.reuse)
        return job, out, polys, wall, spacing, kept

    with ThreadPoolExecutor(args.jobs) as pool:
        done = list(pool.map(convert, jobs))
    rows = []
    for (s, b), out, polys, wall, spacing, kept in done:
        pic = to_picture(polys, centre, height)
        length = drawn_m(pic)
        t_ours = plot_time(out, args.config)
        mine = score(ink(pic, height), dark)
        mine_bands = bands(ink(pic, height), dark) if name.startswith("ramp") else None

        def hatched_time(pitch):
            _, npz = hat.run(pitch)
            g = os.path.join(tmp, "hatched.ngc")
            write_gcode(hat.lines(npz), centre, height, g)
            return plot_time(g, args.config, "--order", "best")

        if length > 0.05 and s != "stipple":
            pitch, _ = hat.match(length, lambda p: hat.run(p)[0])
        else:
            pitch, _ = hat.match(t_ours, hatched_time)
        # at the same plot time: hatched's lines in a nearest-neighbour order, timed by the
        # same planner (`estimate --order greedy`)
        p_t, t_ht = hat.match(t_ours, lambda p: hatched_nn_time(hat, p, centre, height, tmp,
                                                                args.config))
        at_time = score(ink(hat.lines(hat.run(p_t)[1]), height), dark)
        h_len, npz = hat.run(pitch)
        h_pic = hat.lines(npz)
        theirs = score(ink(h_pic, height), dark)
        g = os.path.join(tmp, "hatched.ngc")
        write_gcode(h_pic, centre, height, g)
        t_h = plot_time(g, args.config, "--order", "best")
        dots = sum(1 for p in pic if len(p) == 1 or np.ptp(p, axis=0).max() < 1e-6)
        rows.append(dict(photo=name, style=s, budget=b, spacing=spacing, drawn_m=length, kept=kept,
                         own=own_score(pic, photo, height), h_time=at_time, h_t_pitch=p_t,
                         h_t_s=t_ht, h_t_m=hat.run(p_t)[0],
                         dots=dots, t_ours=t_ours, wall=wall, ours=mine, hatched=theirs,
                         h_pitch=pitch, h_drawn_m=h_len, t_h=t_h, dark=float(dark.mean()),
                         bands=mine_bands,
                         h_bands=bands(ink(h_pic, height), dark) if mine_bands else None))
    hat.close()
    return rows


_NN_TIMES: dict = {}


def hatched_nn_time(hat, pitch, centre, height, tmp, config) -> float:
    """hatched's lines at this pitch in a nearest-neighbour order, timed by the planner."""
    _, npz = hat.run(pitch)
    if npz not in _NN_TIMES:
        g = os.path.join(tmp, "hatched-nn.ngc")
        write_gcode(hat.lines(npz), centre, height, g)
        _NN_TIMES[npz] = plot_time(g, config, "--order", "greedy")
    return _NN_TIMES[npz]


_PICTURES: dict = {}


def own_score(pic, photo, height) -> float:
    """The converter's own tone score of a drawing (`inputs/image/score.py`, what --style auto
    ranks the styles by): our lines (picture mm, y down) against vplotter's picture."""
    from vplotter.inputs.image import load, score
    from vplotter.inputs.strokes import Stroke

    if photo not in _PICTURES:
        _PICTURES[photo] = load.load(photo, WIDTH_MM, height, PEN_MM)
    picture = _PICTURES[photo]
    strokes = [Stroke(np.column_stack([p[:, 0], height - p[:, 1]])) for p in pic]
    return score.correlation(strokes, picture, PEN_MM)


def clock(s: float) -> str:
    s = int(round(s))
    return f"{s // 3600}:{s // 60 % 60:02d}:{s % 60:02d}"


def print_rows(rows):
    r0 = rows[0]
    print(f"\n{r0['photo']}  (mean darkness {r0['dark']:.3f})")
    print(f"{'style':9} {'budget':6} {'spacing':>7} {'drawn m':>8} {'dots':>6} {'plot':>8} "
          f"{'conv s':>6} | {'corr':>6} {'hatched':>7} {'ratio':>6} | {'SSIM':>6} {'hatched':>7} "
          f"| {'ink':>6} {'hatched':>7} | {'h pitch':>7} {'h m':>6} {'h plot':>8} | "
          f"{'own':>6} | {'h@time':>6} {'diff':>6} {'h m':>5} {'h plot':>8}")
    for r in rows:
        o, t = r["ours"], r["hatched"]
        ratio = o["corr"] / t["corr"] if t["corr"] > 0 else float("inf")
        r["ratio"] = ratio
        print(f"{r['style']:9} {r['budget']:6} {r['spacing'] or 0:7.2f} {r['drawn_m']:8.1f} "
              f"{r['dots']:6d} {clock(r['t_ours']):>8} {r['wall']:6.1f} | {o['corr']:6.3f} "
              f"{t['corr']:7.3f} {ratio:6.2f} | {o['ssim']:6.3f} {t['ssim']:7.3f} | "
              f"{o['ink']:6.3f} {t['ink']:7.3f} | {r['h_pitch']:7.2f} {r['h_drawn_m']:6.1f} "
              f"{clock(r['t_h']):>8} | {r['own']:6.3f} | {r['h_time']['corr']:6.3f} "
              f"{o['corr'] - r['h_time']['corr']:+6.3f} {r['h_t_m']:5.1f} {clock(r['h_t_s']):>8}")
    for b in dict.fromkeys(r["budget"] for r in rows):
        mine = [r for r in rows if r["budget"] == b and r["style"] != "auto"]
        ran = [r for r in rows if r["budget"] == b and r["style"] == "auto"]
        if not mine:
            continue
        top = max(mine, key=lambda r: r["ours"]["corr"])
        if ran:                       # what `--style auto` kept, measured on its own file
            pick, what = ran[0], f"auto kept {ran[0]['kept']}"
        else:                         # the style with the best own score (auto's old ranking)
            pick = max(mine, key=lambda r: r["own"])
            what = f"best own score {pick['style']}"
        print(f"  {b}: {what} (own score {pick['own']:.3f}; bench {pick['ours']['corr']:.3f}, "
              f"best style {top['style']} {top['ours']['corr']:.3f}, "
              f"{pick['ours']['corr'] - top['ours']['corr']:+.3f}); hatched at the same plot "
              f"time {pick['h_time']['corr']:.3f}")
    if rows[0]["bands"]:
        print("grey ramp: ink per area in 5 bands, light to dark (darkness of the band first)")
        for r in rows:
            b = r["bands"]
            rising = all(y1 > y0 for (_, y0), (_, y1) in zip(b, b[1:]))
            print(f"  {r['style']:9} {r['budget']:4} " +
                  "  ".join(f"{d:.2f}:{i:.3f}" for d, i in b) + ("  rises" if rising else
                                                               "  DOES NOT RISE"))
        r = rows[0]
        print(f"  {'hatched':9} {'':4} " + "  ".join(f"{d:.2f}:{i:.3f}" for d, i in r["h_bands"]))


def main() -> None:
    if len(sys.argv) > 1 and sys.argv[1] == "--hatched-worker":
        hatched_worker()
        return
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("folder", nargs="?")
    ap.add_argument("--make", metavar="DIR", help="write the test pictures into DIR and stop")
    ap.add_argument("--budgets", default="1h,3h")
    ap.add_argument("--styles", default=",".join(STYLES))
    ap.add_argument("--only", default="", help="comma-separated picture names (no suffix)")
    ap.add_argument("--hatched-python", default="/tmp/venv-hatched/bin/python")
    ap.add_argument("--config", default=os.path.join(ROOT, "config.toml"))
    ap.add_argument("--keep", metavar="DIR", help="keep our G-code files there")
    ap.add_argument("--reuse", action="store_true",
                    help="with --keep: read back the G-code files already there")
    ap.add_argument("--jobs", type=int, default=2, help="conversions at once")
    ap.add_argument("--json", metavar="FILE", help="also write every figure there")
    args = ap.parse_args()
    if args.keep:
        os.makedirs(args.keep, exist_ok=True)
    if args.make:
        make(args.make)
        return
    if not args.folder:
        ap.error("give a folder of pictures (or --make DIR)")
    photos = sorted(os.path.join(args.folder, f) for f in os.listdir(args.folder)
                    if f.lower().endswith(SUFFIXES))
    if args.only:
        keep = set(args.only.split(","))
        photos = [p for p in photos if os.path.splitext(os.path.basename(p))[0] in keep]
    styles, budgets = args.styles.split(","), args.budgets.split(",")
    print(f"{WIDTH_MM:g} mm wide, pen {PEN_MM} mm, {args.config}; ink rendered at {RASTER} px/mm, "
          f"compared per {CELL / RASTER:g} mm cell after a Gaussian blur of {SIGMA_MM:g} mm")
    every = []
    with tempfile.TemporaryDirectory() as tmp:
        for photo in photos:
            rows = one_photo(photo, styles, budgets, args, tmp)
            print_rows(rows)
            sys.stdout.flush()
            every.extend(rows)
    if args.json:
        with open(args.json, "w") as f:
            json.dump(every, f, indent=1)
    print("\nsummary: ours corr / hatched corr at the same drawn length (stipple: same plot time)")
    groups = {"photographs": [r for r in every if r["photo"].startswith("photo")],
              "line art": [r for r in every if r["photo"].startswith("line")]}
    for label, rs in groups.items():
        if not rs:
            continue
        print(f"  {label}:")
        for s in styles:
            mine = [r for r in rs if r["style"] == s]
            if mine:
                worst = min(mine, key=lambda r: r["ratio"])
                print(f"    {s:9} min ratio {worst['ratio']:.2f} ({worst['photo']} "
                      f"{worst['budget']}), mean {np.mean([r['ratio'] for r in mine]):.2f}")
        best = {}
        for r in (r for r in rs if r["style"] != "auto"):
            k = (r["photo"], r["budget"])
            best[k] = max(best.get(k, 0), r["ratio"])
        k = min(best, key=best.get)
        print(f"    best style per picture and budget: min ratio {best[k]:.2f} ({k[0]} {k[1]})")
    print("\nat the same plot time (hatched in a nearest-neighbour order): best style - hatched")
    for label, rs in groups.items():
        best = {}
        for r in (r for r in rs if r["style"] != "auto"):
            k = (r["photo"], r["budget"])
            d = r["ours"]["corr"] - r["h_time"]["corr"]
            if k not in best or d > best[k][0]:
                best[k] = (d, r["style"])
        if best:
            k = min(best, key=lambda q: best[q][0])
            print(f"  {label}: least {best[k][0]:+.3f} ({k[0]} {k[1]}, {best[k][1]})")
        for s in styles:
            mine = [r["ours"]["corr"] - r["h_time"]["corr"] for r in rs if r["style"] == s]
            if mine:
                print(f"    {s:9} min {min(mine):+.3f}, mean {np.mean(mine):+.3f}")
    autos = [r for r in every if r["style"] == "auto"]
    if autos:
        print("\n--style auto against the best style by the bench's measure (its own file):")
        for r in autos:
            rest = [q for q in every if q["photo"] == r["photo"] and q["budget"] == r["budget"]
                    and q["style"] != "auto"]
            top = max(rest, key=lambda q: q["ours"]["corr"]) if rest else None
            print(f"  {r['photo']:18} {r['budget']:3} kept {r['kept']:14} {r['ours']['corr']:.3f}"
                  + (f", best {top['style']} {top['ours']['corr']:.3f} "
                     f"({r['ours']['corr'] - top['ours']['corr']:+.3f})" if top else "")
                  + f", convert {r['wall']:.1f} s")
    ramp = [r for r in every if r["bands"]]
    if ramp:
        bad = [f"{r['style']} {r['budget']}" for r in ramp
               if not all(y1 > y0 for (_, y0), (_, y1) in zip(r["bands"], r["bands"][1:]))]
        print(f"  grey ramp: ink rises with darkness in every style: "
              f"{'yes' if not bad else 'NO: ' + ', '.join(bad)}")


if __name__ == "__main__":
    main()
