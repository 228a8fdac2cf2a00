"""Numbering the marks found in a photo: which candidate is which mark of pattern.csv.

Mark 1 is the candidate whose ellipse is several times a mark's (FIRST_SIZE: the ring
between its two circles, or the whole of its outer circle where the photo is too coarse to
show the inner one); the hole inside its inner circle is left out. Its nearest marks on the
page (along the row and along the column) are looked for among the candidates nearest it in
the photo, both ways round where the sense of rotation allows (a photo is not a mirror
image: the page's y is up, the photo's down). From those three an affine map of the page
into the photo, then a homography from every mark matched so far, predicts where each mark
should be; the candidate nearest a prediction (within MATCH_SHARE of the marks' spacing
there) is that mark. The hypothesis that matches most marks wins (among equals, the one
whose mark 1 is largest); matches off the homography through them all, or of another size,
are dropped. What was not matched is said with where it should have been.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vplotter.calibration import photo_camera as cam
from vplotter.calibration.photo_marks import Candidates

FIRST_SIZE = 2.5              # mark 1's ellipse area over a mark's, at least
SIZE_RANGE = (0.3, 3.0)       # a mark's ellipse area over the typical mark's
MARK_FILL = 0.7               # a circle round a dot fills its ellipse (mark 1's ring: 0.5)
MATCH_SHARE = 0.3             # a candidate this near a prediction is that mark
FIT_SHARE = 0.12              # and then this near the homography through all of them
SAME_SIZE = 1.8               # a mark's ellipse area within this factor of the others'
FIRST_TRIES, NEAR_TRIES = 8, 6
RING_LEAD = 2.0               # mark 1 by its second circle: this much darker than the next
RING_MIN = 0.02               # (darkness against the paper, 0..1)


@dataclass
class Numbering:
    found: dict[int, int]           # mark id -> candidate index
    predicted: np.ndarray           # (N, 2) where each mark of `ids` should be (pixels)
    radius_px: float                # a mark's hole: the median radius
    extra: int = 0                  # mark-like shapes off the pattern's grid


def _map(src, dst):
    """A homography through 4+ points, or the affine map through 3."""
    if len(src) >= 4:
        return cam.homography(src, dst)
    a = np.column_stack((src, np.ones(len(src))))
    m = np.linalg.lstsq(a, dst, rcond=None)[0].T
    return np.vstack((m, [0, 0, 1]))


def _cross(a, b) -> float:
    return float(a[0] * b[1] - a[1] * b[0])


def _spacing(g: np.ndarray) -> float:
    d = np.hypot(*(g[:, None, :] - g[None, :, :]).transpose(2, 0, 1))
    d[d == 0] = np.inf
    return float(d.min(axis=1).min())


def _local_scale(h, g):
    """Pixels per page mm of the map h at the page points g."""
    e = 1.0
    with np.errstate(invalid="ignore", divide="ignore"):   # a degenerate map: NaN, no match
        p = cam.apply(h, g)
        px = cam.apply(h, g + [e, 0]) - p
        py = cam.apply(h, g + [0, e]) - p
    return np.sqrt(np.abs(px[:, 0] * py[:, 1] - px[:, 1] * py[:, 0])) / e


def _grow(g, xy, seed: dict[int, int], spacing: float) -> dict[int, int]:
    from scipy.spatial import cKDTree

    tree = cKDTree(xy)
    found = dict(seed)
    for _ in range(8):
        ids = sorted(found)
        h = _map(g[ids], xy[[found[i] for i in ids]])
        pred = cam.apply(h, g)
        if not np.all(np.isfinite(pred)):
            return found
        tol = MATCH_SHARE * spacing * _local_scale(h, g)
        dist, near = tree.query(pred)
        order = np.argsort(dist)
        new, used = {}, set()
        for i in order:
            if dist[i] <= tol[i] and near[i] not in used:
                new[int(i)] = int(near[i])
                used.add(near[i])
        if new == found or len(new) < 3:
            return new if len(new) >= len(found) else found
        found = new
    return found


def _neighbours(g: np.ndarray, first: int) -> tuple[int, int]:
    """The marks nearest mark 1 on the page in two directions at least 60 degrees apart."""
    d = g - g[first]
    dist = np.hypot(*d.T)
    dist[first] = np.inf
    b = int(np.argmin(dist))
    cos = (d @ d[b]) / (np.maximum(dist, 1e-9) * dist[b])
    dist2 = np.where(np.abs(cos) < 0.5, dist, np.inf)
    return b, int(np.argmin(dist2))


def _typical(c: Candidates, n: int) -> float:
    """A mark's ellipse area: the median of the n largest round holes."""
    round_ = np.sort(c.area[c.fill > MARK_FILL])[::-1][:n]
    return float(np.median(round_)) if len(round_) else 1.0


def _hypotheses(c: Candidates, one: int, typical: float, sense: float):
    """(pool, xy, seeds): the candidates that may be marks (mark 1 last), and the pairs of
    them nearest mark 1 that may be its neighbours along the row and the column."""
    size = c.area / typical
    inside = np.hypot(*(c.xy - c.xy[one]).T) < 0.6 * np.sqrt(c.area[one] / np.pi)
    pool = np.flatnonzero((size >= SIZE_RANGE[0]) & (size <= SIZE_RANGE[1])
                          & (c.fill > MARK_FILL) & ~inside)
    xy = np.vstack((c.xy[pool], c.xy[one]))
    d = xy[:-1] - c.xy[one]
    near = np.argsort(np.hypot(*d.T))[:NEAR_TRIES]
    seeds = []
    for i in near:
        for j in near:
            if i == j or np.sign(_cross(d[i], d[j])) != -sense:
                continue
            if abs(d[i] @ d[j]) <= 0.8 * np.hypot(*d[i]) * np.hypot(*d[j]):
                seeds.append((int(i), int(j)))
    return np.append(pool, one), xy, seeds


def number(c: Candidates, ids: list[int], g: np.ndarray, rings=None) -> Numbering | None:
    """Number the candidates c after the page positions g (G-code mm, y up) of the marks
    `ids`; None where no mark 1 is seen. Where no candidate is large enough for mark 1,
    rings(indices) (photo_marks.rings) may name it: the one round hole whose second circle
    stands out (RING_LEAD times the next one's darkness)."""
    first = ids.index(1) if 1 in ids else 0
    b, cc = _neighbours(g, first)
    sense = np.sign(_cross(g[b] - g[first], g[cc] - g[first]))
    spacing = _spacing(g)
    typical = _typical(c, len(ids))
    ones = np.flatnonzero(c.area >= FIRST_SIZE * typical)
    ones = ones[np.argsort(-c.area[ones])][:FIRST_TRIES]
    if not len(ones) and rings is not None:
        marks = np.flatnonzero(c.fill > MARK_FILL)
        if len(marks) >= 2:
            dark = rings(marks)
            top = np.argsort(-dark)
            if dark[top[0]] > RING_LEAD * max(dark[top[1]], RING_MIN):
                ones = marks[top[:1]]
    best, score = None, (-1, 0.0)
    for one in ones:
        pool, xy, seeds = _hypotheses(c, one, typical, sense)
        for i, j in seeds:
            found = _grow(g, xy, {first: len(xy) - 1, b: i, cc: j}, spacing)
            if (len(found), c.area[one]) > score:
                score = (len(found), c.area[one])
                best = ({k: int(pool[v]) for k, v in found.items()}, found, xy)
    if best is None:
        return None
    back, found, xy = best
    back, h = _consistent(c, g, back, first, spacing)
    others = [v for k, v in back.items() if k != first]
    radius = float(np.median(np.sqrt(c.area[others] / np.pi))) if others else 1.0
    return Numbering({ids[k]: v for k, v in back.items()}, cam.apply(h, g), radius,
                     _extra(c, back, typical, back[first]) if first in back else 0)


def _consistent(c: Candidates, g, back: dict[int, int], first: int, spacing: float):
    """The matches that agree with the homography through all of them (within
    FIT_SHARE of the spacing) and are a mark's size (SAME_SIZE of their median): shapes
    that happened to lie near a prediction (a texture's holes) are not marks."""
    for _ in range(3):
        ks = sorted(back)
        if len(ks) < 4:
            break
        h = _map(g[ks], c.xy[[back[k] for k in ks]])
        off = np.hypot(*(cam.apply(h, g[ks]) - c.xy[[back[k] for k in ks]]).T)
        tol = FIT_SHARE * spacing * _local_scale(h, g[ks])
        area = np.array([c.area[back[k]] for k in ks])
        mid = float(np.median([a for k, a in zip(ks, area) if k != first] or [1.0]))
        same = (area >= mid / SAME_SIZE) & (area <= mid * SAME_SIZE)
        keep = (off <= tol) & (same | (np.array(ks) == first))
        if keep.all():
            break
        back = {k: back[k] for k, ok in zip(ks, keep) if ok}
    ks = sorted(back)
    return back, _map(g[ks], c.xy[[back[k] for k in ks]])


def _extra(c: Candidates, back: dict[int, int], typical: float, one: int) -> int:
    """Round holes of a mark's size that are no mark of the pattern (nor mark 1's inner
    circle)."""
    size = c.area / typical
    inside = np.hypot(*(c.xy - c.xy[one]).T) < 0.6 * np.sqrt(c.area[one] / np.pi)
    like = (size >= 1 / SAME_SIZE) & (size <= SAME_SIZE) & (c.fill > MARK_FILL) & ~inside
    like[list(back.values())] = False
    return int(like.sum())
