"""Photo styles: time, memory, strokes, length, lifts and tone fidelity per style.

Two synthetic pictures (made here, nothing downloaded): a photo-like 1200 x 900 PNG
(gradients, discs, a ring, text, soft noise) and the same scene at 12 megapixels
(4000 x 3000) as a JPEG (quality 90), both drawn 300 mm wide with a 0.5 mm pen, every style
at spacing 1.5 mm. Each (picture, style) runs in a fresh process, so its peak resident size
(ru_maxrss, which Linux carries across exec: the pictures are made in another child) is its own; tracemalloc's peak (Python and numpy allocations, not Pillow's
decoder) is given beside it.

Tone fidelity: the strokes are drawn as lines of pen width into a raster at 10 px/mm (Pillow
ImageDraw), reduced to the picture's pixels (box filter: ink fraction per pixel), and both that
and the picture's darkness are blurred at 1 mm (Gaussian); the figure is the Pearson
correlation of ink with darkness over the picture. Plot time is the drawing at 4 mm/s, the
pen-up travel in the order made (no reordering) at 8 mm/s, and 0.3 s a lift.

Run: python -m bench.image_styles [--png out_dir]   (out_dir: a rendering per style)
"""

from __future__ import annotations

import importlib.util
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
import tracemalloc

import numpy as np


WIDTH_MM, PEN_MM, SPACING_MM = 300.0, 0.5, 1.5
STYLES = ("hatch", "spiral", "squiggle", "stipple", "flow")


def scene(w: int, h: int):
    """A photo-like RGB image: sky gradient, lit discs, a ring, text, soft noise."""
    from PIL import Image, ImageDraw, ImageFilter, ImageFont

    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
    u, v = xx / w, yy / h
    rgb = np.stack([0.35 + 0.5 * v, 0.55 + 0.35 * v, 0.9 - 0.2 * u], -1)
    for cx, cy, r, col in ((0.3, 0.55, 0.22, (0.9, 0.6, 0.3)), (0.72, 0.4, 0.15, (0.2, 0.3, 0.5)),
                           (0.55, 0.8, 0.1, (0.05, 0.05, 0.05))):
        dist = np.hypot((u - cx) * w / h, v - cy)
        shade = np.clip(1.1 - 0.9 * np.hypot(u - cx + r / 3, v - cy + r / 3) / r, 0.15, 1)
        inside = dist < r
        rgb[inside] = (np.array(col) * shade[inside, None])
    ring = np.abs(np.hypot((u - 0.15) * w / h, v - 0.2) - 0.1) < 0.012
    rgb[ring] = 0.1
    rng = np.random.default_rng(5)
    noise = rng.normal(0, 0.04, (h // 8 + 1, w // 8 + 1)).astype(np.float32)
    noise = np.kron(noise, np.ones((8, 8), np.float32))[:h, :w]
    rgb = np.clip(rgb + noise[..., None], 0, 1)
    im = Image.fromarray((rgb * 255).astype(np.uint8)).filter(ImageFilter.GaussianBlur(w / 1200))
    draw = ImageDraw.Draw(im)
    font = ImageFont.load_default(size=max(10, h // 12))
    draw.text((int(0.05 * w), int(0.8 * h)), "V-plotter 42", fill=(20, 20, 20), font=font)
    draw.rectangle([int(0.8 * w), int(0.7 * h), int(0.95 * w), int(0.95 * h)], fill=(240, 240, 240))
    return im


def render(st, width_mm: float, height_mm: float, px_per_mm: float = 10.0):
    """Ink 0..1 at px_per_mm: the strokes as lines of pen width."""
    from PIL import Image, ImageDraw

    w, h = round(width_mm * px_per_mm), round(height_mm * px_per_mm)
    im = Image.new("L", (w, h), 0)
    draw = ImageDraw.Draw(im)
    lw = max(1, round(PEN_MM * px_per_mm))
    for s in st:
        p = s.pts * px_per_mm
        xy = list(zip(p[:, 0].tolist(), (h - p[:, 1]).tolist()))
        if len(xy) == 1:
            x, y = xy[0]
            draw.ellipse([x - lw / 2, y - lw / 2, x + lw / 2, y + lw / 2], fill=255)
        else:
            draw.line(xy, fill=255, width=lw, joint="curve")
    return im


def fidelity(st, pic) -> float:
    from PIL import Image, ImageFilter

    hh, ww = pic.darkness.shape
    ink = render(st, pic.width_mm, pic.height_mm).resize((ww, hh), Image.Resampling.BOX)
    sigma = 1.0 / pic.mm_per_px
    ink = np.asarray(ink.filter(ImageFilter.GaussianBlur(sigma)), dtype=np.float64)
    dark = Image.fromarray(np.round(pic.darkness * 255).astype(np.uint8))     # 8 bits: Pillow blurs L
    dark = np.asarray(dark.filter(ImageFilter.GaussianBlur(sigma)), dtype=np.float64)
    return float(np.corrcoef(ink.ravel(), dark.ravel())[0, 1])


def one(path: str, style_name: str, png_dir: str | None) -> dict:
    from vplotter.inputs.image import style
    from vplotter.inputs.image.load import aspect, load

    tracemalloc.start()
    t0 = time.perf_counter()
    height = WIDTH_MM / aspect(path)
    pic = load(path, WIDTH_MM, height, pen_mm=PEN_MM)
    t1 = time.perf_counter()
    st = style(style_name)(pic, SPACING_MM, PEN_MM)
    t2 = time.perf_counter()
    peak_py = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    length = sum(s.length_mm() for s in st)
    ends = [(s.pts[0], s.pts[-1]) for s in st]
    travel = sum(float(np.hypot(*(b[0] - a[1]))) for a, b in zip(ends, ends[1:]))
    pts = np.concatenate([s.pts for s in st]) if st else np.zeros((0, 2))
    inside = bool(np.all((pts >= -1e-9) & (pts <= [pic.width_mm + 1e-9, pic.height_mm + 1e-9])))
    out = dict(load_s=t1 - t0, style_s=t2 - t1, rss_mb=rss, py_mb=peak_py / 2**20,
               strokes=len(st), points=len(pts), length_m=length / 1000, lifts=len(st),
               travel_m=travel / 1000, hours=(length / 4 + travel / 8 + 0.3 * len(st)) / 3600,
               fidelity=fidelity(st, pic), px=list(pic.darkness.shape[::-1]), inside=inside)
    if png_dir:
        render(st, pic.width_mm, pic.height_mm, 4).point(lambda v: 255 - v).save(
            os.path.join(png_dir, f"{os.path.basename(path)}.{style_name}.png"))
    return out


def main() -> None:
    if len(sys.argv) > 1 and sys.argv[1] == "--make":       # in a child: keeps our RSS small
        scene(1200, 900).save(sys.argv[2])
        scene(4000, 3000).save(sys.argv[3], quality=90)
        return
    if len(sys.argv) > 1 and sys.argv[1] == "--one":
        png = sys.argv[4] if len(sys.argv) > 4 else None
        print(json.dumps(one(sys.argv[2], sys.argv[3], png)))
        return
    png_dir = sys.argv[sys.argv.index("--png") + 1] if "--png" in sys.argv else None
    from vplotter.inputs.image import STYLES as known

    with tempfile.TemporaryDirectory() as tmp:
        photo = os.path.join(tmp, "photo.png")
        big = os.path.join(tmp, "photo12mp.jpg")
        subprocess.run([sys.executable, "-m", "bench.image_styles", "--make", photo, big],
                       check=True)
        print(f"{'picture':14} {'style':9} {'px':>9} {'load s':>6} {'style s':>7} {'RSS MB':>6} "
              f"{'py MB':>6} {'strokes':>7} {'points':>7} {'drawn m':>7} {'lifts':>5} "
              f"{'travel m':>8} {'hours':>5} {'fidelity':>8}")
        for path in (photo, big):
            for name in STYLES:
                if name not in known or importlib.util.find_spec(
                        f"vplotter.inputs.image.{name}") is None:
                    print(f"{os.path.basename(path):14} {name:9} (not in this tree)")
                    continue
                cmd = ([sys.executable, "-m", "bench.image_styles", "--one", path, name]
                       + ([png_dir] if png_dir else []))
                r = subprocess.run(cmd, capture_output=True, text=True)
                if r.returncode:
                    last = (r.stderr.strip().splitlines() or ["?"])[-1]
                    print(f"{os.path.basename(path):14} {name:9} failed: {last}")
                    continue
                m = json.loads(r.stdout)
                print(f"{os.path.basename(path):14} {name:9} {m['px'][0]:>4}x{m['px'][1]:<4} "
                      f"{m['load_s']:6.2f} {m['style_s']:7.2f} {m['rss_mb']:6.0f} {m['py_mb']:6.0f} "
                      f"{m['strokes']:7d} {m['points']:7d} {m['length_m']:7.1f} {m['lifts']:5d} "
                      f"{m['travel_m']:8.1f} {m['hours']:5.1f} {m['fidelity']:8.3f}"
                      + ("" if m["inside"] else "  OUTSIDE"))


if __name__ == "__main__":
    main()
