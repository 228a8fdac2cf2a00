"""Generated SVG drawings of smooth cubic Béziers under nested skewed matrices, with their true
geometry computed here (de Casteljau), independently of vplotter.

`make(seed, ...)` returns the SVG text and the true curves in G-code mm (default placement:
the page of `width` x `height` mm centred on X0 Y0, +Y up). The drawing has Inkscape layers,
each a `<g transform="matrix(...)">` with one or two nested matrix groups inside (skew,
non-uniform scale, rotation); paths are chains of C1-smooth cubic segments, open or closed
(`Z`); many pairs of path ends lie 0.01-0.1 mm apart on the page (end to start, end to end,
start to start, and an open end next to a node of a closed path), the two paths far apart
in the file and often in other groups or layers.

Used by tests/test_order_keeps_the_lines.py and bench/order_geometry.py.
"""

from __future__ import annotations

import numpy as np

NS = ('xmlns="http://www.w3.org/2000/svg" '
      'xmlns:inkscape="http://www.inkscape.org/namespaces/inkscape"')


def true_bezier(ctrl: np.ndarray, n: int = 2000) -> np.ndarray:
    """Dense points of a Bézier curve by de Casteljau (ctrl: (k, 2) control points)."""
    t = np.linspace(0, 1, n)[:, None]
    pts = [np.broadcast_to(c, (n, 2)) for c in np.asarray(ctrl, dtype=float)]
    while len(pts) > 1:
        pts = [(1 - t) * a + t * b for a, b in zip(pts[:-1], pts[1:])]
    return pts[0]


def _matrix(rng, centre) -> np.ndarray:
    """A 3x3 affine map about `centre` with rotation, skew and non-uniform scale."""
    a = rng.uniform(-0.6, 0.6)
    rot = np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
    skew = np.array([[1.0, rng.uniform(-0.45, 0.45)], [rng.uniform(-0.3, 0.3), 1.0]])
    scale = np.diag(rng.uniform(0.6, 1.5, 2))
    A = rot @ skew @ scale
    c = np.asarray(centre, dtype=float)
    m = np.eye(3)
    m[:2, :2] = A
    m[:2, 2] = c - A @ c + rng.uniform(-8, 8, 2)
    return m


def _svg_matrix(m: np.ndarray) -> str:
    a, c, e = m[0]
    b, d, f = m[1]
    return "matrix(" + ",".join(repr(float(v)) for v in (a, b, c, d, e, f)) + ")"


def _apply(m: np.ndarray, pts: np.ndarray) -> np.ndarray:
    return np.asarray(pts, dtype=float) @ m[:2, :2].T + m[:2, 2]


class _Path:
    def __init__(self, group: int, segs: list[np.ndarray], closed: bool):
        self.group, self.segs, self.closed = group, segs, closed

    def d(self) -> str:
        s = self.segs
        out = [f"M {float(s[0][0][0])!r} {float(s[0][0][1])!r}"]
        for c in s:
            out.append("C " + " ".join(f"{x!r} {y!r}" for x, y in c[1:].tolist()))
        if self.closed:
            out.append("Z")
        return " ".join(out)


def _chain(rng, start: np.ndarray, k: int, size: float, closed: bool,
           end: np.ndarray | None = None) -> list[np.ndarray]:
    """k C1-smooth cubic segments from `start` (user units), closed back to it, or ending at
    `end` when given."""
    pts = [np.asarray(start, dtype=float)]
    heading = rng.uniform(0, 2 * np.pi)
    for i in range(k):
        heading += rng.uniform(-1.2, 1.2)
        pts.append(pts[-1] + size * rng.uniform(0.5, 1.0) * np.array([np.cos(heading),
                                                                         np.sin(heading)]))
    if closed:
        pts[-1] = pts[0]
    elif end is not None:
        pts[-1] = np.asarray(end, dtype=float)
    segs = []
    h = size * 0.35 * np.array([np.cos(heading), np.sin(heading)])
    t_out = rng.normal(0, size * 0.3, 2)
    first_out = t_out
    for i in range(k):
        p0, p3 = pts[i], pts[i + 1]
        c1 = p0 + t_out
        if closed and i == k - 1:
            c2 = p3 - first_out                  # smooth through the closing node too
        else:
            c2 = p3 - rng.normal(0, size * 0.3, 2) - h * 0.2
        segs.append(np.array([p0, c1, c2, p3]))
        t_out = p3 - c2                          # the next segment leaves smoothly
    return segs


def _groups(rng, n_layers: int, width: float, height: float) -> list:
    """Per layer a matrix group, and inside it one or two nested matrix groups: (layer, chain
    of matrices from the layer down, full map to G-code mm)."""
    page = np.array([[1.0, 0, -width / 2], [0, -1.0, height / 2], [0, 0, 1]])
    groups = []              # (layer, chain of matrices from the layer down, full map)
    for lay in range(n_layers):
        centre = rng.uniform([0.3 * width, 0.3 * height], [0.7 * width, 0.7 * height])
        m_layer = _matrix(rng, centre)
        for g in range(2):
            m1 = _matrix(rng, centre)
            chain = [m_layer, m1]
            if g == 1:
                chain.append(_matrix(rng, centre))
            full = page.copy()
            for m in chain:
                full = full @ m
            groups.append((lay, chain, full))
    return groups


def _svg(groups: list, paths: list, n_layers: int, width: float, height: float, n: int):
    """(svg text, true curves) of the paths in their groups, layer by layer."""
    body = []
    true = []
    for lay in range(n_layers):
        gis = [i for i, g in enumerate(groups) if g[0] == lay]
        m_layer = groups[gis[0]][1][0]
        body.append(f'<g inkscape:groupmode="layer" id="layer{lay + 1}" '
                    f'inkscape:label="L{lay + 1}" transform="{_svg_matrix(m_layer)}">')
        for gi in gis:
            chain = groups[gi][1]
            for m in chain[1:]:
                body.append(f'<g transform="{_svg_matrix(m)}">')
            for p in paths:
                if p.group == gi:
                    body.append(f'<path fill="none" stroke="black" d="{p.d()}"/>')
                    true.append(np.concatenate([true_bezier(_apply(groups[gi][2], c), n)
                                                for c in p.segs]))
            body.append("</g>" * (len(chain) - 1))
        body.append("</g>")
    text = (f'<svg {NS} width="{width}mm" height="{height}mm" viewBox="0 0 {width} {height}">'
            + "\n".join(body) + "</svg>\n")
    return text, true


def make(seed: int = 0, n_paths: int = 60, n_layers: int = 2, width: float = 300.0,
         height: float = 400.0, pairs: int = 20, gap=(0.01, 0.1), n: int = 2000):
    """(svg text, true curves: list of (N, 2) arrays in G-code mm, one per path; n points per
    cubic segment)."""
    rng = np.random.default_rng(seed)
    groups = _groups(rng, n_layers, width, height)
    size = 0.04 * min(width, height)
    paths: list[_Path] = []

    def user(gi: int, mm: np.ndarray) -> np.ndarray:
        full = groups[gi][2]
        return _apply(np.linalg.inv(full), mm[None, :])[0]

    def mm_of(gi: int, p: np.ndarray) -> np.ndarray:
        return _apply(groups[gi][2], p[None, :])[0]

    def random_start(gi: int) -> np.ndarray:
        # somewhere on the middle of the page, in the group's own coordinates
        mm = rng.uniform([-0.3 * width, -0.3 * height], [0.3 * width, 0.3 * height])
        return user(gi, mm)

    def new_path(gi: int, closed: bool, start=None, end=None) -> _Path:
        s = random_start(gi) if start is None else start
        return _Path(gi, _chain(rng, s, int(rng.integers(2, 6)) if not closed else
                                int(rng.integers(3, 6)), size, closed, end), closed)

    def offset() -> np.ndarray:
        a = rng.uniform(0, 2 * np.pi)
        return rng.uniform(*gap) * np.array([np.cos(a), np.sin(a)])

    for _ in range(pairs):
        ga, gb = (int(v) for v in rng.integers(0, len(groups), 2))
        kind = rng.choice(["end-start", "end-end", "start-start", "ring"])
        a = new_path(ga, closed=bool(kind == "ring"))
        paths.append(a)
        if kind == "ring":
            node = a.segs[int(rng.integers(0, len(a.segs)))][0]
            target = mm_of(ga, node) + offset()
            b = new_path(gb, False, end=user(gb, target)) if rng.random() < 0.5 else \
                new_path(gb, False, start=user(gb, target))
        else:
            at = a.segs[-1][-1] if kind != "start-start" else a.segs[0][0]
            target = user(gb, mm_of(ga, at) + offset())
            b = new_path(gb, False, start=target) if kind != "end-end" else \
                new_path(gb, False, end=target)
        paths.append(b)
    while len(paths) < n_paths:
        paths.append(new_path(int(rng.integers(0, len(groups))), bool(rng.random() < 0.35)))
    perm = rng.permutation(len(paths))      # the near pairs far apart in the file
    paths = [paths[i] for i in perm]

    return _svg(groups, paths, n_layers, width, height, n)
