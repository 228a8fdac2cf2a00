"""Cross-check the SVG reader against svgelements' own geometry, file by file.

    python -m bench.reference.svg_crosscheck FILE.svg ...   (e.g. $(find /usr/share -name '*.svg'))

For each file: vplotter's strokes (tolerance 0.005 mm) and svgelements' transformed segments
(lines exact, curves at 400 points each), both in G-code mm with the default placement,
densified to 1 µm; prints the largest distance each way. svgelements is not an oracle: it gets
skewed arcs and a symbol's viewBox wrong and draws display:none differently, so files with
those differ for its reasons. Needs scipy (a test dependency)."""

import sys
import warnings

import numpy as np
import svgelements as S
from scipy.spatial import cKDTree

from vplotter.errors import InputError
from vplotter.inputs import svg

warnings.filterwarnings("ignore")
MM_PER_PX = 25.4 / 96
# text is drawn in Hershey fonts (svg_text.py); svgelements has no glyphs to compare it with
svg._Reader.draw_text = lambda self, node, ctx: None


def densify(polys, step=0.001):
    out = []
    for p in polys:
        if len(p) == 1:
            out.append(p)
            continue
        for a, b in zip(p[:-1], p[1:]):
            out.append(a + (b - a) * np.linspace(0, 1, int(np.hypot(*(b - a)) / step) + 2)[:, None])
    return np.concatenate(out) if out else np.zeros((0, 2))


def reference(path, w_mm, h_mm):
    ref = []
    for e in S.SVG.parse(path, ppi=96).elements():
        if not isinstance(e, S.Shape) or isinstance(e, S.Text):
            continue
        if e.values.get("visibility") in ("hidden", "collapse"):
            continue
        cur = []
        for seg in e.segments(transformed=True):
            if isinstance(seg, S.Move):
                if cur:
                    ref.append(np.concatenate(cur))
                cur = []
                continue
            if isinstance(seg, (S.Line, S.Close)):
                pts = np.array([[seg.start.x, seg.start.y], [seg.end.x, seg.end.y]], dtype=float)
            else:
                pts = np.asarray(seg.npoint(np.linspace(0, 1, 400)), dtype=float)
            cur.append(np.column_stack((pts[:, 0] * MM_PER_PX - w_mm / 2,
                                        h_mm / 2 - pts[:, 1] * MM_PER_PX)))
        if cur:
            ref.append(np.concatenate(cur))
    return ref


def main(files):
    n_ok = n_diff = n_err = 0
    for f in files:
        try:
            d = svg.read(f, 0.005, warn=lambda m: None)
        except InputError as e:
            n_err += 1
            print(f"error  {e}")
            continue
        a = densify([s.pts for s in d.strokes])
        b = densify(reference(f, d.width_mm, d.height_mm))
        if len(a) == 0 and len(b) == 0:
            n_ok += 1
            continue
        if len(a) == 0 or len(b) == 0:
            n_diff += 1
            print(f"DIFF   {f}: vplotter {len(a)} points, svgelements {len(b)}")
            continue
        d1, d2 = cKDTree(b).query(a)[0].max(), cKDTree(a).query(b)[0].max()
        ok = max(d1, d2) <= 0.02
        n_ok += ok
        n_diff += not ok
        if not ok:
            print(f"DIFF   {f}: vplotter->svgelements {d1:.4f} mm, svgelements->vplotter {d2:.4f} mm")
    print(f"{len(files)} files: {n_ok} agree within 0.02 mm, {n_diff} differ, {n_err} errors")


if __name__ == "__main__":
    main(sys.argv[1:])
