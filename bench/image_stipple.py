"""Stipples on a photo-like picture: time, tour length and how well the ink follows the tone.

A synthetic picture 300 mm wide (1200 x 1600 px: gradients, discs, a soft shadow, noise). For
N in (5k, 20k, 50k) dots (spacing_mm chosen so that N = sum(darkness) px area / spacing²):
- place: wall time of sampling + Lloyd (stipple.points), and the Lloyd rounds' evenness (the
  coefficient of variation of nearest-neighbour distances over the darkest quarter);
- tour: wall time of the TSP tour (stipple_tour.tour) for the tsp=True point set, its length against
  the nearest-neighbour path alone, the line drawn after the splits and the pen lifts;
- tone: the dots (pen_mm discs) and the TSP strokes rendered with Pillow's ImageDraw at 10 px/mm,
  both the rendering and the darkness blurred (GaussianBlur, sigma 1 mm, and 2 x spacing: 1 mm
  is finer than the dots at 5k), Pearson correlation of ink with darkness. For the line it is
  given for both density models: rho = d (as the dots) and rho = d² (what tsp=True uses).

Times are wall-clock seconds on this (shared, 2-core) machine. Run: python -m bench.image_stipple
"""

from __future__ import annotations

import math
import time

import numpy as np
from PIL import Image, ImageDraw, ImageFilter
from scipy.spatial import cKDTree

from vplotter.inputs.image import stipple, stipple_tour
from vplotter.inputs.image.picture import Picture

WIDTH_MM, PEN_MM, PX_MM = 300.0, 0.5, 10


def photo(h: int = 1600, w: int = 1200, seed: int = 1) -> Picture:
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:h, 0:w] / max(h, w)
    d = 0.15 + 0.5 * x * y                                         # a soft diagonal gradient
    d += 0.25 * np.exp(-((x - 0.3) ** 2 + (y - 0.8) ** 2) / 0.02)  # a shadow
    for cx, cy, r, v in ((0.5, 0.4, 0.18, 0.85), (0.25, 0.2, 0.08, 0.0), (0.6, 1.0, 0.12, 0.55)):
        d = np.where((x - cx) ** 2 + (y - cy) ** 2 < r * r, v, d)  # discs, one of them white
    d[: h // 12] = 0.0                                              # a white band at the top
    d += rng.normal(0, 0.04, d.shape)
    d = np.clip(d, 0, 1).astype(np.float32)
    return Picture(d, WIDTH_MM, WIDTH_MM * h / w, "synthetic")


def render(pic: Picture, dots: np.ndarray | None, lines: list[np.ndarray]) -> Image.Image:
    w, h = round(pic.width_mm * PX_MM), round(pic.height_mm * PX_MM)
    im = Image.new("L", (w, h), 0)
    draw = ImageDraw.Draw(im)
    r = PEN_MM / 2 * PX_MM

    def px(p):
        return [(float(a) * PX_MM, (pic.height_mm - float(b)) * PX_MM) for a, b in p]

    if dots is not None:
        for x, y in px(dots):
            draw.ellipse((x - r, y - r, x + r, y + r), fill=255)
    for ln in lines:
        if len(ln) == 1:
            x, y = px(ln)[0]
            draw.ellipse((x - r, y - r, x + r, y + r), fill=255)
        else:
            draw.line(px(ln), fill=255, width=max(1, round(PEN_MM * PX_MM)), joint="curve")
    return im


def correlation(pic: Picture, ink: Image.Image, sigma_mm: float = 1.0) -> float:
    dark = Image.fromarray(np.round(pic.darkness * 255).astype(np.uint8)).resize(ink.size,
                                                                              Image.BILINEAR)
    blur = ImageFilter.GaussianBlur(sigma_mm * PX_MM)
    a = np.asarray(ink.filter(blur), dtype=float).ravel()
    b = np.asarray(dark.filter(blur), dtype=float).ravel()
    return float(np.corrcoef(a, b)[0, 1])


def evenness(pts: np.ndarray, pic: Picture) -> float:
    dd, _ = cKDTree(pts).query(pts, k=2)
    dark = pic.at(pts) > np.quantile(pic.darkness, 0.75)
    nn = dd[dark, 1]
    return float(nn.std() / nn.mean())


def length(p: np.ndarray) -> float:
    return float(np.hypot(*np.diff(p, axis=0).T).sum())


def run() -> None:
    pic = photo()
    dark_area = float(pic.darkness.sum()) * pic.mm_per_px * (pic.height_mm / pic.darkness.shape[0])
    dark2_area = float((pic.darkness.astype(float) ** 2).sum()) * pic.mm_per_px ** 2
    print(f"picture {pic.darkness.shape[1]} x {pic.darkness.shape[0]} px, "
          f"{pic.width_mm:.0f} x {pic.height_mm:.0f} mm, mean darkness {pic.darkness.mean():.2f}")
    print("(corr: Pearson of blurred ink and darkness, blur sigma 1 mm / 2 x spacing)")
    print("| N dots | spacing mm | place s | CV nn (start -> Lloyd) | dots corr | tsp N "
          "| tour s | NN path m | tour m | drawn m | lifts | line corr rho=d² | line corr rho=d |")
    print("| --- " * 13 + "|")
    for n in (5_000, 20_000, 50_000):
        s = math.sqrt(dark_area / n)
        t0 = time.perf_counter()
        pts = stipple.points(pic, s)
        t_place = time.perf_counter() - t0
        cv0 = evenness(stipple.points(pic, s, iterations=0), pic)
        cv1 = evenness(pts, pic)
        ink = render(pic, pts, [])
        c_dots = correlation(pic, ink), correlation(pic, ink, 2 * s)
        # the line: the same N through tsp=True's density (rho = d²)
        s2 = math.sqrt(dark2_area / n)
        tp = stipple.points(pic, s2, gamma=2.0)
        t0 = time.perf_counter()
        order = stipple_tour.tour(tp)
        t_tour = time.perf_counter() - t0
        nn = stipple_tour.nearest_neighbour(tp)
        pieces = stipple_tour.split(tp[order], pic, s2, 2.0)
        ink = render(pic, None, pieces)
        c_line = correlation(pic, ink), correlation(pic, ink, 2 * s2)
        # the same tour made with rho = d (as the dots)
        lines1 = stipple_tour.split(pts[stipple_tour.tour(pts)], pic, s, 1.0)
        c_line1 = correlation(pic, render(pic, None, lines1))
        print(f"| {len(pts)} | {s:.2f} | {t_place:.2f} | {cv0:.2f} -> {cv1:.2f} "
              f"| {c_dots[0]:.3f} / {c_dots[1]:.3f} "
              f"| {len(tp)} | {t_tour:.2f} | {length(tp[nn]) / 1000:.1f} "
              f"| {length(tp[order]) / 1000:.1f} | {sum(length(p) for p in pieces) / 1000:.1f} "
              f"| {len(pieces) - 1} | {c_line[0]:.3f} / {c_line[1]:.3f} | {c_line1:.3f} |",
              flush=True)


if __name__ == "__main__":
    run()
