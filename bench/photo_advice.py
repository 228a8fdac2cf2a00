"""When does a photo's face show? The measure behind the converter's advice (drawing/advice.py).

For face pictures (scikit-image's astronaut cut to a portrait, the camera man, the cat: made by
`python -m bench.photo_tone --make DIR`, plus `portrait.jpg`, the astronaut cut to 3:4; a
picture without a known face is scored whole), every style drawn at fixed spacings (in pen
widths: the tone, the share of the paper one pen line in every spacing covers) at two sizes
(300 and 150 mm wide: the detail, lines across the picture), straight from the style
functions (no budget, no planner: the style's own tone curve for that spacing):

- `ink`: the share of the picture's darkness (mean of 1 - Y, linear light) the drawing lays
  as ink (the strokes as lines of the pen width, `score.ink` unblurred in spirit: the mean of
  its blurred coverage);
- `corr`: `score.correlation` over the whole picture (ink and darkness blurred at 1 mm, the
  converter's own measure);
- `face`: the same correlation over the face's box only (the face's own features: eyes, mouth,
  the shading of the cheeks), and its share of the face's darkness laid as ink (`face ink`).

`--check`: the advice followed. For every picture and style, `vplotter info PICTURE --json
--width W --max-time T` (the installed CLI, a subprocess, ./config.toml); when it advises, the
time and the width it suggests are run the same way, and each must come out at a spacing of at
most GOOD_PENS pen widths (no advice of its own). Printed: the spacing of each, in pen widths.

Run (from the repository root, in vplotter's venv):
    python -m bench.photo_advice DIR [--styles hatch,spiral,...] [--widths 300,150]
    python -m bench.photo_advice DIR --check [--styles ...] [--width 300] [--time 1h]
"""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import tempfile

import numpy as np

PEN_MM = 0.5
# the face's box in each picture: (left, top, right, bottom) as shares of its width and height
FACES = {"portrait.jpg": (0.12, 0.08, 0.45, 0.36),
         "photo-astronaut.png": (0.30, 0.08, 0.52, 0.34),
         "photo-camera.png": (0.42, 0.15, 0.56, 0.34),
         "photo-cat.png": (0.28, 0.12, 0.75, 0.90)}
PENS = (1.2, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0, 6.0, 8.0, 11.0, 16.0, 22.0)
STYLES = ("hatch", "spiral", "squiggle", "stipple", "tsp")     # tsp: stipple --tsp


def portrait(folder: str) -> None:
    """portrait.jpg: the astronaut cut to 3:4, her face in the upper left third."""
    from PIL import Image

    src = os.path.join(folder, "photo-astronaut.png")
    out = os.path.join(folder, "portrait.jpg")
    if os.path.exists(src) and not os.path.exists(out):
        Image.open(src).convert("RGB").crop((60, 0, 420, 480)).save(out, quality=90)


def corr(a: np.ndarray, b: np.ndarray) -> float:
    a, b = a.ravel(), b.ravel()
    if not a.std() > 0 or not b.std() > 0:
        return 0.0
    return float(np.corrcoef(a, b)[0, 1])


def measure(path: str, style: str, width_mm: float, pens: float) -> dict:
    from vplotter.inputs import image
    from vplotter.inputs.image import load, score

    h = width_mm / load.aspect(path)
    pic = load.load(path, width_mm, h, PEN_MM)
    extra = {"tsp": True} if style == "tsp" else {}
    made = image.style("stipple" if style == "tsp" else style)(pic, pens * PEN_MM, PEN_MM,
                                                               **extra)
    ink, dark = score.ink(made, pic, PEN_MM), score.darkness(pic)
    rows, cols = ink.shape
    x0, y0, x1, y1 = FACES.get(os.path.basename(path), (0, 0, 1, 1))
    box = (slice(int(y0 * rows), int(y1 * rows)), slice(int(x0 * cols), int(x1 * cols)))
    return {"lines": width_mm / (pens * PEN_MM), "ink": float(ink.mean() / dark.mean()),
            "corr": corr(ink, dark), "face": corr(ink[box], dark[box]),
            "face_ink": float(ink[box].mean() / dark[box].mean()),
            "drawn_m": sum(s.length_mm() for s in made) / 1000}


def info(path: str, style: str, width: float, limit: str) -> dict:
    """`vplotter info --json` of a photo: its spacing (mm) and its advice."""
    argv = ["vplotter", "info", path, "--json", "--width", f"{width:g}", "--max-time", limit,
            "--style", *style.split()]
    env = {**os.environ, "XDG_STATE_HOME": tempfile.mkdtemp()}
    out = subprocess.run(argv, capture_output=True, text=True, env=env, check=True).stdout
    got = json.loads(out)
    spacing = next(float(m.group(1)) for d in got["details"]
                   if (m := re.match(r"spacing ([0-9.]+) mm for a plot time", d)))
    return {"spacing": spacing, "advice": got["advice"]}


def check(folder: str, styles: list[str], width: float, limit: str) -> None:
    """The advice followed: its time and its width must each give a spacing within GOOD_PENS."""
    from vplotter.drawing import advice

    print("picture style | asked: pens | --max-time T: pens ok | --width W: pens ok")
    for name in sorted(n for n in os.listdir(folder) if n in FACES):
        path = os.path.join(folder, name)
        for style in styles:
            kind = "tsp" if style == "tsp" else style
            style_args = "stipple --tsp" if style == "tsp" else style
            good = advice.GOOD_PENS[kind]
            first = info(path, style_args, width, limit)
            row = f"{name} {style} | {first['spacing'] / PEN_MM:.1f}"
            if not first["advice"]:
                print(row + " | no advice", flush=True)
                continue
            text = first["advice"][0]
            t = re.search(r"--max-time (\S+?)\)", text)
            w = re.search(r"--width (\d+)", text)
            for what, (wd, lim) in (("--max-time", (width, t and t.group(1))),
                                    ("--width", (w and float(w.group(1)), limit))):
                if lim is None or wd is None:
                    row += f" | {what}: not suggested"
                    continue
                got = info(path, style_args, wd, lim)
                ok = got["spacing"] <= good * PEN_MM * 1.0001 and not got["advice"]
                row += (f" | {what} {lim if what == '--max-time' else f'{wd:g}'}: "
                        f"{got['spacing'] / PEN_MM:.1f} {'ok' if ok else 'FAILS'}")
            print(row, flush=True)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("folder")
    ap.add_argument("--styles", default=",".join(STYLES))
    ap.add_argument("--widths", default="300,150")
    ap.add_argument("--pens", default=",".join(map(str, PENS)))
    ap.add_argument("--check", action="store_true", help="follow the converter's advice")
    ap.add_argument("--width", type=float, default=300.0, help="--check: the width asked for")
    ap.add_argument("--time", default="1h", help="--check: the budget asked for")
    a = ap.parse_args(argv)
    portrait(a.folder)
    if a.check:
        check(a.folder, a.styles.split(","), a.width, a.time)
        return
    names = sorted(n for n in os.listdir(a.folder) if n in FACES)
    print("picture style width spacing/pen lines ink corr face face_ink drawn_m")
    for name in names:
        for style in a.styles.split(","):
            for w in map(float, a.widths.split(",")):
                for p in map(float, a.pens.split(",")):
                    r = measure(os.path.join(a.folder, name), style, w, p)
                    print(f"{name} {style} {w:g} {p:g} {r['lines']:.0f} {r['ink']:.3f} "
                          f"{r['corr']:.3f} {r['face']:.3f} {r['face_ink']:.3f} "
                          f"{r['drawn_m']:.1f}", flush=True)


if __name__ == "__main__":
    main()
