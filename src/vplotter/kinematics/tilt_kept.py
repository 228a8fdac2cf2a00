"""What the tilting gondola's machine keeps between calls (kinematics/tilt_steps.py lays out
and solves steps with it): the planned windows' vertices and balances (`remember`), the
balance reused between the planner's calls (`balance`: the same points, or moved on by one;
`carry`: the same points with points put in, which the planner tells), the slopes the
search for the cords' turning points works out, which refine asks for again (`known_slopes`,
carried through the points put in), and the cords' derivatives the planner asks for at the
starts and the ends of a window's pieces (`jets`), which the window's layout takes.

The planner and the schedule have each a machine: the windows are kept here, by machine.
A window lives as long as its vertices' array: the planner's, which its blocks' vertices are
views of, so that a block finds its window by the array it views (`find`) however long after
it was planned (a draw plans the whole drawing to check it, keeps the plan and plays it
after: pipeline.validate). The last WINDOWS are also kept outright (the planner's next
calls, and blocks that are copies)."""

from __future__ import annotations

import functools
import weakref
from dataclasses import dataclass

import numpy as np

from vplotter.kinematics.tilt import FEW
from vplotter.kinematics.tilt_along import along, cord_jets, slopes_along

WINDOWS = 2                               # windows kept (the last ones the planner planned)


@dataclass
class Window:
    """A planned window's vertices, their balance (Gondola.solve), its pieces' directions,
    and its layout once a block asked for it. The vertices are the planner's array, held by a
    weak reference: the window is kept in this module's tables for as long as that array
    lives, and must not be what keeps it alive (every window of a long drawing would then be
    kept for the process's life)."""

    ref: weakref.ref                # to the planner's vertices' array
    state: tuple
    e: np.ndarray | None = None
    d: np.ndarray | None = None
    lay: object | None = None       # its tilt_steps.Layout
    jets0: tuple | None = None      # (e, r, qj) of jets() at the pieces' starts (`brief`)
    jets1: tuple | None = None      # and at their ends

    @property
    def verts(self) -> np.ndarray | None:
        """The window's vertices (None once the planner's array is gone)."""
        return self.ref()


_WINDOWS: list = []     # (machine, Window): the planner and the schedule have each a machine
_BY_VERTS: dict = {}    # id of a vertices' array -> [(its weakref, machine, Window)]
_LAID: list = [None]    # a weakref to the window whose layout was made last (one layout kept)
_NEXT: list = [None]    # (root's weakref, machine, window, offset): where the last found ended


def _machine(kin) -> tuple:
    g = kin.gondola
    return (g.d_mm, g.v, g.a, kin.stretch)


def windows(kin) -> list:
    key = kin.__dict__.get("_tilt_key")
    if key is None:
        key = kin._tilt_key = _machine(kin)
    return [w for m, w in _WINDOWS if m == key and w.ref() is not None]


def remember(kin, xy: np.ndarray, state: tuple) -> None:
    """Keep the balance at a window's vertices (from `inverse`) for its blocks' steps, while
    the array xy lives (it must not change: the planner's arrays do not)."""
    key = _machine(kin)
    mine = [i for i, (m, _) in enumerate(_WINDOWS) if m == key]
    for i in reversed(mine[:len(mine) - WINDOWS + 1]):
        _slim(_WINDOWS.pop(i)[1])
    root = _root(xy)
    if root is not xy:        # (the planner's windows are arrays of their own: a view's
        return                # window would die with the view, before its blocks)
    w = Window(weakref.ref(xy), state)
    _WINDOWS.append((key, w))
    for _, old in _WINDOWS[:-4 * WINDOWS]:
        _slim(old)
    del _WINDOWS[:-4 * WINDOWS]
    kept = _BY_VERTS.get(id(root))
    if kept is None:
        kept = _BY_VERTS[id(root)] = []
        weakref.finalize(root, _BY_VERTS.pop, id(root), None)
    kept.append((weakref.ref(root), key, w))


def _slim(w: Window) -> None:
    """A window the planner is done with keeps of its balance what its layout takes once the
    cords' derivatives at its pieces' ends are kept (phi and the cords: `layout_state`)."""
    if w.jets0 is not None and w.jets1 is not None:
        w.state = (w.state[0], *(None,) * 5, w.state[6])


def layout_state(kin, w: Window, e: np.ndarray) -> tuple:
    """The balance a window's layout takes along its pieces' directions e: its kept one,
    solved again where a slimmed window's kept derivatives are not along e (they always are
    for the planner's windows)."""
    if w.state[1] is not None or all(np.array_equal(j[0], e) for j in (w.jets0, w.jets1)):
        return w.state
    v = w.verts
    return kin.gondola.solve(v[:, 0], v[:, 1])


def find(kin, a: np.ndarray) -> tuple | None:
    """(window, i) when the rows a are the window's vertices i .. i + len(a) - 1, as a view of
    the same array; else None. The blocks come in order: where the last one found ended is
    tried first (its first row the same memory as a's; asking for a view's address costs
    more)."""
    root = _root(a)
    key = kin.__dict__.get("_tilt_key")
    if key is None:
        key = kin._tilt_key = _machine(kin)
    n = len(a)
    nxt = _NEXT[0]
    if nxt is not None and nxt[0]() is root and nxt[1] == key:
        w, i = nxt[2], nxt[3]
        v = w.verts
        if i + n <= len(v) and v.strides == a.strides and np.shares_memory(a[0], v[i]):
            _NEXT[0] = (nxt[0], key, w, i + n)
            return w, i
    kept = _BY_VERTS.get(id(root))
    if not kept:
        return None
    for ref, m, w in reversed(kept):
        if ref() is not root or m != key:
            continue
        i = _row_in(a, w.verts)
        if i is not None:
            _NEXT[0] = (ref, key, w, i + n)
            return w, i
    return None


def laid(w: Window, make) -> object:
    """The window's layout, made by make() the first time; the last window's is let go (the
    blocks come window by window)."""
    if w.lay is None:
        last = _LAID[0] and _LAID[0]()
        if last is not None and last is not w:
            last.lay = None
        w.lay = make()
        _LAID[0] = weakref.ref(w)
    return w.lay


def _at(a: np.ndarray) -> int:
    """The address of a's first element."""
    return a.ctypes.data


def _row_in(a: np.ndarray, v: np.ndarray) -> int | None:
    """i when the rows a are v's rows i .. i + len(a) - 1 (a view of the same memory, the
    same strides), else None."""
    if v.strides != a.strides:
        return None
    i, rest = divmod(_at(a) - _at(v), v.strides[0])
    return i if not rest and 0 <= i and i + len(a) <= len(v) else None


def _root(a: np.ndarray) -> np.ndarray:
    while isinstance(a.base, np.ndarray):
        a = a.base
    return a


def balance(kin, xy: np.ndarray) -> tuple:
    """Gondola.solve at the points xy (N, 2), reusing what the machine solved last: the same
    points, a window's vertices less the last or the first (the starts and the ends of its
    pieces), or the points of the last solve moved on by one (one new point solved); else
    solved (from Gondola's table of phi)."""
    n = len(xy)
    seen = getattr(kin, "_tilt_solves", [])
    for m, st in reversed([*seen, *((w.verts, w.state) for w in windows(kin))]):
        if len(m) == n + 1:
            for a in (0, 1):
                if np.array_equal(m[a:a + n], xy):
                    return tuple(_rows(v, slice(a, a + n)) for v in _got(st))
        elif len(m) == n and n > 1 and np.array_equal(m, xy):
            return _got(st)
        elif len(m) == n and n > 1 and np.array_equal(m[1:], xy[:-1]):
            new = kin.gondola.solve(xy[-1:, 0], xy[-1:, 1])
            st = tuple(_joined(_rows(v, slice(1, n)), w) for v, w in zip(_got(st), new))
            break
        elif len(m) == n - 1 and n > 2 and np.array_equal(m, xy[1:]):
            new = kin.gondola.solve(xy[:1, 0], xy[:1, 1])
            st = tuple(_joined(w, v) for v, w in zip(_got(st), new))
            break
        elif len(m) == n - 1 and n > 2 and np.array_equal(m, xy[:-1]):
            new = kin.gondola.solve(xy[-1:, 0], xy[-1:, 1])
            st = tuple(_joined(v, w) for v, w in zip(_got(st), new))
            break
    else:
        st = kin.gondola.solve(xy[:, 0], xy[:, 1])
    if n > 2:
        kin._tilt_solves = [*seen[-2:], (xy.copy(), st)]
    return st


def _planned(kin, xy: np.ndarray, put: bool = False):
    """`balance` at the planner's vertices xy: the planner hands the array it asked
    end_slopes or carry about to carry and ends (its arrays do not change), so that array
    itself is the one asked about last; else balance. put: a carried balance may come as it
    was kept (a _Put not gathered yet)."""
    last = kin.__dict__.get("_tilt_last")
    if last is not None and last[0] is xy:
        return last[1] if put else _got(last[1])
    return balance(kin, xy)


class _Put:
    """The balance at the planner's vertices with points put in (`carry`), gathered when first
    asked for (`got`): the rows `rows` of the balance `st` at the vertices before, then at
    each (where, balance) of `puts` the balance solved at points put in. When the planner
    puts points in twice before it asks (its turning points, then refine's), the second is
    gathered once, from the first's balance."""

    def __init__(self, st, rows: np.ndarray, put: np.ndarray, solved):
        self.puts = []
        if isinstance(st, _Put) and st.out is None:
            for where, sol in st.puts:                # where rows take st's points put in
                at = np.full(len(st.rows), -1)
                at[where] = np.arange(len(where))
                w = at.take(rows)
                hit = np.flatnonzero(w >= 0)
                if len(hit):
                    self.puts.append((hit, _rows(sol, w.take(hit))))
            st, rows = st.st, st.rows.take(rows)
        self.st, self.rows, self.out = _got(st), rows, None
        if len(put):
            self.puts.append((put, solved))

    def got(self) -> tuple:
        if self.out is None:
            out = tuple(_rows(v, self.rows) for v in self.st)
            for where, sol in self.puts:
                for o, v in zip(out, sol):
                    _put(o, where, v)
            self.out, self.st, self.puts = out, None, None
        return self.out


def _got(st) -> tuple:
    """A balance, gathered if it is a _Put."""
    return st.got() if isinstance(st, _Put) else st


def end_slopes(kin, xy: np.ndarray, e: np.ndarray, d: np.ndarray) -> tuple:
    """For the pieces xy + s e, 0 <= s <= d (N): the cords' slopes (N, 2) at their starts and
    at their ends (the balance at the starts solved as `balance` solves and keeps it, with the
    last piece's end where xy is the planner's vertices but the last: the vertices' balance
    at once; an end where the next piece starts takes that start's; the slopes kept for
    refine: `known_slopes`), and f(rows, motors, sign) that makes the
    function a search for the cords' turning points needs: at s along those rows' pieces, sign
    times the slope and the bend of each row's cord (the balance solved from phi interpolated
    between the piece's ends)."""
    g = kin.gondola
    n = len(xy)
    whole = _whole(xy)            # the planner's vertices: xy and the last piece's end
    whole = xy if whole is None else whole
    st = balance(kin, whole)
    kin._tilt_last = (whole, st)
    phi0 = st[0][:n]
    if kin.stretch == 0.0:          # (the vertices' share worked out once for both ends)
        terms = g.slope_terms(whole[:, 0], whole[:, 1], st)

        def at_rows(xs, es, rows):
            return slopes_along(terms, rows, es)
    else:
        def at_rows(xs, es, rows):
            return slopes(kin, xs, es, tuple(_rows(v, rows) for v in st))
    k0 = at_rows(xy, e, slice(0, n))
    ends = np.empty_like(xy)              # xy + e d, column by column (d[:, None]: slower)
    for j in (0, 1):
        np.multiply(e[:, j], d, out=ends[:, j])
    ends += xy
    same = following(whole, ends)
    k1 = np.empty_like(k0)
    phi1 = np.empty(n)
    at = np.flatnonzero(same)
    nxt = at + 1
    if len(at) == len(whole) - 1:                # all follow on: views, no copies
        at, nxt = slice(0, len(at)), slice(1, len(at) + 1)
    k1[at] = at_rows(whole[nxt], e[at], nxt)
    phi1[at] = st[0][nxt]
    other = np.flatnonzero(~same)
    if len(other):
        end_st = g.solve(ends[other, 0], ends[other, 1], phi0[other])     # (from the start's)
        k1[other] = slopes(kin, ends[other], e[other], end_st)
        phi1[other] = end_st[0]
    kin._tilt_slopes = (whole, lambda: (e, k0, k1)) if whole is not xy else None

    def search(rows, m, sign):
        p, u, dd = xy[rows], e[rows], d[rows]
        a, b = phi0[rows], phi1[rows] - phi0[rows]
        left = m == 0

        def f(s):
            pts = p + u * s[:, None]
            state = g.solve(pts[:, 0], pts[:, 1], a + b * (s / dd))
            r, _ = g.jets(pts, u, state)
            ql, qr = cord_jets(r, kin.stretch)
            return (sign * np.where(left, ql[1], qr[1]), sign * np.where(left, ql[2], qr[2]))

        if len(rows) <= FEW:        # a few rows: each in Python floats (numpy's overhead is most)
            f.one = [functools.partial(_turn_one, kin, *row) for row in zip(
                p.tolist(), u.tolist(), dd.tolist(), a.tolist(), b.tolist(), left.tolist(),
                sign.tolist())]
        return f

    return k0, k1, search


def _jets_one(kin, x: float, y: float, ex: float, ey: float, phi: float = 0.0) -> tuple:
    """The motor coordinates' triples along (ex, ey) at one point, in Python floats (the
    balance solved from phi)."""
    g = kin.gondola
    r, _ = g.jets_at(x, y, ex, ey, g.state_one(x, y, phi))
    return cord_jets(r, kin.stretch)


def _turn_one(kin, p, u, d, a, b, left, sign, s) -> tuple:
    """search's function at one row in Python floats: sign times the slope and the bend."""
    q = _jets_one(kin, p[0] + u[0] * s, p[1] + u[1] * s, u[0], u[1],
                  a + b * (s / d))[0 if left else 1]
    return sign * q[1], sign * q[2]


def bend_one(kin, x: float, y: float, ex: float, ey: float) -> tuple:
    """The motor coordinates' bends along (ex, ey) at one point, in Python floats."""
    return tuple(q[2] for q in _jets_one(kin, x, y, ex, ey))


def following(xy: np.ndarray, ends: np.ndarray) -> np.ndarray:
    """Which pieces (starts xy, ends ends) end where the next one starts (within a rounding
    error: the balance there is the next start's); xy may have one row more (the last
    piece's end vertex)."""
    n = len(ends)
    same = np.zeros(n, dtype=bool)
    m = min(n, len(xy) - 1)
    if m > 0:
        gap = np.abs(ends[:m] - xy[1:m + 1])
        same[:m] = np.maximum(gap[:, 0], gap[:, 1]) <= 1e-9
    return same


def _whole(xy: np.ndarray) -> np.ndarray | None:
    """The array whose rows but the last xy is (a view of its first rows), else None."""
    base = xy.base
    if (isinstance(base, np.ndarray) and base.ndim == 2 and len(base) == len(xy) + 1
            and _row_in(xy, base) == 0):
        return base
    return None


def slopes(kin, xy, e, st) -> np.ndarray:
    """(N, 2) the motor coordinates' slopes along e at xy, the balance there st."""
    if kin.stretch == 0.0:
        return kin.gondola.slopes(xy, e, st)
    r, _ = kin.gondola.jets(xy, e, st)
    ql, qr = cord_jets(r, kin.stretch)
    return np.stack((ql[1], qr[1]), axis=-1)


def carry(kin, old: np.ndarray, new: np.ndarray, piece: np.ndarray, end: np.ndarray) -> None:
    """Keep the balance at new: old's vertices with points put in on its pieces (new[0] is
    old[0], new[j + 1] lies on piece[j], and is old's vertex piece[j] + 1 where end[j]:
    refine.put_in), taken from the balance at old (`balance`: the planner asked for it, or for
    all but one of its rows) and solved at the points put in."""
    st = _planned(kin, old, put=True)
    rows = np.concatenate(([0], piece + 1))
    put = np.flatnonzero(~end) + 1
    solved = kin.gondola.solve(new[put, 0], new[put, 1]) if len(put) else None
    out = _Put(st, rows, put, solved)
    kin._tilt_solves = [*getattr(kin, "_tilt_solves", [])[-2:], (new.copy(), out)]
    kin._tilt_last = (new, out)
    known = getattr(kin, "_tilt_slopes", None)
    kin._tilt_slopes = None
    if known is not None and known[0] is old:
        kin._tilt_slopes = (new, lambda: _carried(kin, known[1](), new, solved, piece, put))


def _carried(kin, slopes_old: tuple, new, solved, piece, put) -> tuple:
    """The slopes (e, k0, k1) of the pieces through new from those through old (carry's
    arguments; solved: the balance at the points put in): a piece's part keeps the slope at
    an old vertex, the points put in are worked out (along the piece they lie on)."""
    e, k0, k1 = (a.take(piece, axis=0) for a in slopes_old)    # (a[piece]: slower)
    if len(put):
        kp = slopes(kin, new.take(put, axis=0), e.take(put - 1, axis=0), solved)
        k1[put - 1] = kp                       # the end of the part before the point
        k0[put] = kp                           # and the start of the part after it
    return e, k0, k1


def known_slopes(kin, xy: np.ndarray, e: np.ndarray) -> np.ndarray | None:
    """The slopes at xy along e when the planner's search for the turning points (end_slopes)
    worked them out for its vertices (carried through the points put in since): xy their rows
    but the last, or but the first. None otherwise."""
    known = getattr(kin, "_tilt_slopes", None)
    if known is None or _root(xy) is not known[0]:
        return None
    verts = known[0]
    first = _row_in(xy, verts) if len(xy) == len(verts) - 1 else None
    if first is None:
        return None
    e_k, k0, k1 = known[1]()
    if e_k.shape != e.shape or not np.abs(e_k - e).max(initial=0.0) <= 1e-12:
        return None
    kin._tilt_slopes = (verts, lambda: (e_k, k0, k1))       # (worked out once)
    return k1 if first else k0


def jets(kin, xy: np.ndarray, e: np.ndarray, state=None) -> tuple:
    """The motor coordinates' triples at the points xy (N, 2) along e (TwoCord._jets of the
    tilting gondola). The planner asks for them at the starts and the ends of the pieces of
    the window it plans: they are kept with the window, for its layout."""
    if state is None:
        state = balance(kin, xy)
    r, _ = kin.gondola.jets(xy, e, state)
    qj = cord_jets(r, kin.stretch)
    mine = windows(kin) if len(xy) > 2 else ()
    if mine and len(mine[-1].verts) == len(xy) + 1:
        w = mine[-1]
        for a, name, other in ((0, "jets0", w.jets1), (1, "jets1", w.jets0)):
            if np.array_equal(w.verts[a:a + len(xy)], xy):
                same = other is not None and np.array_equal(other[0], e)
                setattr(w, name, (other[0] if same else e.copy(), *brief(r, qj)))
                break
    return qj


def ends(kin, verts: np.ndarray, e: np.ndarray) -> tuple:
    """The cords' slopes and bends (2, N) at the starts and the ends of the pieces through
    verts (directions e), without stretch: each vertex's share worked out once for its two
    pieces (Gondola.vertex_terms). Kept with the window for its layout as `jets` keeps its."""
    state = _planned(kin, verts)
    terms = kin.gondola.vertex_terms(verts[:, 0], verts[:, 1], state)
    n = len(e)
    k0, b0 = along(terms, slice(0, n), e)
    k1, b1 = along(terms, slice(1, n + 1), e)
    mine = windows(kin)
    if mine and mine[-1].verts is verts:
        r = state[6]
        (ql, *_), (qr, *_) = terms[1]
        kept = e.copy()                                   # (one copy for both ends)
        for name, at, k in (("jets0", slice(0, n), k0), ("jets1", slice(1, n + 1), k1)):
            cords = (((r[0][at],), (r[1][at],)), ((r[2][at],), (r[3][at],)))
            setattr(mine[-1], name, (kept, *brief(cords, ((ql[at], k[0]), (qr[at], k[1])))))
    return k0, b0, k1, b1


def brief(r, qj) -> tuple:
    """Of the cords' triples r and the motor coordinates' qj, what a layout takes (the cords'
    values, the motor coordinates' values and slopes): kept for a window's whole life."""
    return tuple((rx[:1], ry[:1]) for rx, ry in r), tuple(q[:2] for q in qj)


def _joined(a, b):
    return tuple(map(np.concatenate, zip(a, b))) if isinstance(a, tuple) else np.r_[a, b]


def _rows(v, idx):
    """The rows idx (a slice: views; or indices) of an array, or of each in a tuple."""
    if isinstance(v, tuple):
        return tuple(_rows(x, idx) for x in v)
    return v[idx] if isinstance(idx, slice) else v.take(idx, axis=0)   # (v[idx]: slower)


def _put(v, idx, w) -> None:
    for x, y in (zip(v, w) if isinstance(v, tuple) else ((v, w),)):
        x[idx] = y
