"""Finding the marks of the calibration pattern in a photo, and measuring their centres.

Each mark is a closed circle (3 mm) round a dot; mark 1 has a second circle (6 mm) round
it. On the reduced photo, ink is what is darker than INK_RATIO of the local paper brightness
(a box mean much larger than a mark: uneven light divides out), with the fainter pixels that
touch it. Every hole of the ink (paper enclosed by ink, what is inside it not counted) is a
candidate, with its centre, the area of its ellipse of inertia (4 pi sqrt(det cov)) and
`fill`: its own area over that. A circle round a dot fills most of its ellipse (about 0.9),
mark 1's ring between two circles less (about 0.5), and its ellipse is five times a mark's
(four, where the photo is too coarse to show its inner circle); the holes of the numbers are
far smaller than the circles. All of it is done on label arrays with bincount, no loop over
candidates.

`centre` then measures one mark at full resolution: in a window round it, the circle with
all it encloses (the dot; mark 1: its outer circle and all inside) is taken, and the centroid
of the ink's darkness over it is the centre: the figure is symmetric about the dot, the
number is outside.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

INK_RATIO = 0.85            # ink: darker than this share of the local paper
FAINT_RATIO = 0.93          # or than this, where it touches ink
BACKGROUND_PX = 61          # the box of the local paper brightness (reduced photo)
MIN_HOLE_PX = 8
MIN_AXES = 0.3              # the hole's short axis over its long one
MIN_FILL = 0.2
FAINT_REACH = 1.5           # centre() of a faint circle: ink within this times the radius
RING_ANGLES = 64            # rings(): directions round a candidate
RING_BAND = (1.7, 2.3)      # and the radii, over its own circle's, where mark 1's second is


@dataclass
class Candidates:
    xy: np.ndarray              # (n, 2) centres, full-resolution pixels (x right, y down)
    area: np.ndarray            # ellipse areas, full-resolution pixels^2
    fill: np.ndarray            # hole area / ellipse area


def ink(img: np.ndarray) -> np.ndarray:
    """Hysteresis: pixels darker than INK_RATIO of the local paper, and the fainter ones
    (FAINT_RATIO) that touch them (a thin line's faint stretches close the circles)."""
    from scipy import ndimage

    return _hysteresis(img, ndimage.uniform_filter(img, BACKGROUND_PX, mode="nearest"))


def _hysteresis(img: np.ndarray, paper) -> np.ndarray:
    """Pixels darker than INK_RATIO of the paper (an array, or one value), and the fainter
    ones (FAINT_RATIO) that touch them."""
    from scipy import ndimage

    lab, n = ndimage.label(img < FAINT_RATIO * paper, structure=np.ones((3, 3)))
    strong = np.zeros(n + 1, dtype=bool)
    strong[lab[img < INK_RATIO * paper]] = True
    strong[0] = False
    return strong[lab]


def find(small: np.ndarray, scale: int) -> Candidates:
    """The holes of the ink on the reduced photo that could be marks."""
    from scipy import ndimage

    dark = ink(small)
    lab, n = ndimage.label(~dark)                       # paper; holes: not at the border
    edge = np.unique(np.concatenate((lab[0], lab[-1], lab[:, 0], lab[:, -1])))
    keep = np.ones(n + 1, dtype=bool)
    keep[edge] = False
    keep[0] = False
    lab = np.where(keep[lab], lab, 0)
    idx = np.flatnonzero(lab)
    if len(idx) == 0:
        return Candidates(np.zeros((0, 2)), np.zeros(0), np.zeros(0))
    lv = lab.ravel()[idx]
    y, x = np.divmod(idx, small.shape[1])
    x, y = x.astype(float), y.astype(float)

    def total(w=None):
        return np.bincount(lv, weights=w, minlength=n + 1)[1:]

    a = np.maximum(total(), 1)
    mx, my = total(x) / a, total(y) / a
    sxx = total(x * x) / a - mx ** 2 + 1 / 12
    syy = total(y * y) / a - my ** 2 + 1 / 12
    sxy = total(x * y) / a - mx * my
    det = np.maximum(sxx * syy - sxy ** 2, 1e-12)
    tr = sxx + syy
    disc = np.sqrt(np.maximum(tr * tr / 4 - det, 0))
    axes = np.sqrt(np.maximum(tr / 2 - disc, 0) / (tr / 2 + disc))
    ellipse = 4 * np.pi * np.sqrt(det)
    fill = a / ellipse
    ok = ((a >= MIN_HOLE_PX) & (axes >= MIN_AXES) & (fill >= MIN_FILL)
          & (ellipse <= small.size / 50))
    xy = (np.column_stack((mx, my))[ok] + 0.5) * scale - 0.5
    return Candidates(xy, ellipse[ok] * scale ** 2, fill[ok])


def centre(full: np.ndarray, xy, radius_px: float) -> np.ndarray | None:
    """The centre of the mark near xy (full-resolution pixels), or None where its circle is
    not closed there (cut by the photo's edge, too faint)."""
    from scipy import ndimage

    half = int(np.ceil(1.7 * radius_px + 4))
    x0, y0 = int(round(xy[0])) - half, int(round(xy[1])) - half
    h, w = full.shape
    if x0 < 0 or y0 < 0 or x0 + 2 * half + 1 > w or y0 + 2 * half + 1 > h:
        return None
    crop = full[y0:y0 + 2 * half + 1, x0:x0 + 2 * half + 1].astype(np.float32)
    paper = float(np.percentile(crop, 90))
    if not paper > 0:
        return None
    ys, xs = np.indices(crop.shape)
    region = _closed(crop < INK_RATIO * paper, half)
    if region is None:              # a faint circle (a coarse or blurred photo): as `ink` does,
        # only near it (the faint halo may join the number beside the circle)
        near = np.hypot(xs - half, ys - half) <= FAINT_REACH * radius_px
        region = _closed(_hysteresis(crop, paper) & near, half)
    if region is None:
        return None
    region = ndimage.binary_dilation(region, iterations=2)
    weight = np.clip((paper - crop) / paper - 0.05, 0, None) * region
    total = float(weight.sum())
    if not total > 0:
        return None
    return np.array([float((weight * xs).sum()) / total + x0,
                     float((weight * ys).sum()) / total + y0])


def _closed(dark: np.ndarray, half: int) -> np.ndarray | None:
    """The ink `dark` round the crop's middle with all it encloses, where it encloses
    something (a closed circle); else None."""
    from scipy import ndimage

    lab, _ = ndimage.label(ndimage.binary_fill_holes(dark))
    mid = lab[half - 2:half + 3, half - 2:half + 3]
    labels = mid[mid > 0]
    if labels.size == 0:
        return None
    region = lab == np.bincount(labels).argmax()
    return region if dark[region].sum() < region.sum() else None


def rings(small: np.ndarray, scale: int, c: Candidates, which: np.ndarray) -> np.ndarray:
    """How plainly each candidate `which` has a second circle round its own at twice its
    radius (mark 1's: where the photo is too coarse or blurred to close the ring between
    them, it still shows): the ink's darkness against the paper round it (0..1), its median
    over RING_ANGLES directions at each radius (a number beside a mark darkens a few of them,
    a circle all), then at its darkest between RING_BAND times the radius where the
    candidate's own circle is darkest."""
    from scipy import ndimage

    cx = (c.xy[which, 0] + 0.5) / scale - 0.5
    cy = (c.xy[which, 1] + 0.5) / scale - 0.5
    r = np.sqrt(c.area[which] / np.pi) / scale                 # the hole's radius
    ang = np.linspace(0.0, 2 * np.pi, RING_ANGLES, endpoint=False)
    rho = np.linspace(0.0, 5.0, 26)                            # over the hole's radius
    px = cx[:, None, None] + r[:, None, None] * rho[None, :, None] * np.cos(ang)
    py = cy[:, None, None] + r[:, None, None] * rho[None, :, None] * np.sin(ang)
    b = ndimage.map_coordinates(small, [py.ravel(), px.ravel()], order=1, mode="nearest")
    b = b.reshape(px.shape)
    paper = np.maximum(np.percentile(b.reshape(len(which), -1), 90, axis=1), 1e-6)
    dark = np.median(1.0 - b / paper[:, None, None], axis=2)   # (candidates, radii)
    own = rho[np.argmax(np.where(rho <= 2.4, dark, -np.inf), axis=1)]
    band = ((rho[None, :] >= RING_BAND[0] * own[:, None])
            & (rho[None, :] <= RING_BAND[1] * own[:, None]))
    return np.where(band, dark, -np.inf).max(axis=1)
