"""Where the planner cuts pieces further, on the same straight lines (collinear vertices
change no geometry), so that one trapezoid per piece wastes little time; and the constants of
the corner rule it shares with the planner, and the share of the budget each sharp corner
gets (see `planner`)."""

from __future__ import annotations

import numpy as np

CORNER_SHARE = 0.75    # most of the acceleration budget a corner on a curve may take
MIN_SLOPE = 0.25       # path acceleration is at most budget / MIN_SLOPE
TAU_S = 0.1            # acceleration measurement window for speed jumps at corners
NEAR_TAU = 1.05        # a sharp corner shares the budget with this x TAU_S of motion each side
RATE_STEP = 0.02       # a piece is cut where the rate limit changes by more than this share
MIN_PART_MM = 0.05     # no extra cut closer than this to another
MAX_PARTS = 32         # most equal parts a piece is cut into for the rate limit
RATE_PART_MM = 1.0     # and none shorter than this
SHARP_TRY = np.array([0.02, 0.05, 0.1, 0.15, 0.25, 0.35])   # shares a sharp corner may get


def least(a: np.ndarray) -> np.ndarray:
    """The least value over the motors of an (M, N) array, as a.min(axis=0) (NaN wins),
    without numpy's slow reduction along a short axis.

    The planner keeps its per-motor arrays as (M, N), one row per motor: an operation with a
    per-motor value (M, 1) or a per-piece one (N,) then runs along rows of N, where on
    (N, M) numpy would loop over rows of M in buffers (about ten times slower)."""
    out = a[0]
    for j in range(1, a.shape[0]):
        out = np.minimum(out, a[j])
    return out if a.shape[0] > 1 else out.copy()


def scaled(a: np.ndarray, f: np.ndarray, divide: bool = False) -> np.ndarray:
    """a (N, K) times (or divided by) f (N,) row by row, column by column (see `least`: as
    a * f[:, None], without the buffered loop over rows of K)."""
    out = np.empty(a.shape)
    op = np.divide if divide else np.multiply
    for j in range(a.shape[1]):
        op(a[:, j], f, out=out[:, j])
    return out


def most(a: np.ndarray) -> np.ndarray:
    """The largest value over the motors, as a.max(axis=0) (see `least`)."""
    out = a[0]
    for j in range(1, a.shape[0]):
        out = np.maximum(out, a[j])
    return out if a.shape[0] > 1 else out.copy()


def refine(kin, v_cord, a_cord, verts, cap, line, draw, stop, origin):
    """Cut pieces further where one trapezoid per piece would waste time (the pen stays
    on the same straight line: collinear vertices change no geometry):

    - near a sharp corner: the part of each piece the pen covers within NEAR_TAU x TAU_S
      of the corner (at most v_corner x t + a t^2 / 2, or the speed cap x t) becomes a
      piece of its own. Only it shares the budget with the corner's speed jump; the rest of
      the piece speeds up and slows down with the whole budget (the jump is seen only by
      the 0.1 s windows next to it: see `Planner._profile`).
    - where the step-rate limit on the pen speed (each cord moves at |slope| x v) changes
      along a long piece by more than RATE_STEP: in equal parts, so that the speed follows
      the limit instead of keeping the slowest of the piece all along.
    """
    n = len(verts) - 1
    if n < 1:
        return verts, cap, line, draw, stop, origin
    diff = np.diff(verts, axis=0)
    d = np.hypot(diff[:, 0], diff[:, 1])
    e = scaled(diff, d, divide=True)
    k0s, k1s = kin.slope(verts[:-1], e).T.copy(), kin.slope(verts[1:], e).T.copy()   # (M, N)
    k0, k1 = np.abs(k0s), np.abs(k1s)
    v_col = v_cord[:, None]
    with np.errstate(divide="ignore"):
        vr0 = least(v_col / np.maximum(k0, 1e-9))
        vr1 = least(v_col / np.maximum(k1, 1e-9))
    vcap = np.minimum(cap, np.minimum(vr0, vr1))
    piece_parts, s_parts = _rate_cuts(v_col, k0, k1, d, cap)
    if n > 1:
        jump = np.abs(k0s[:, 1:] - k1s[:, :-1])
        piece, s = _sharp_cuts(a_cord[:, None], jump, k0, k1, d, cap, vcap, vr0, vr1, stop)
        piece_parts += piece
        s_parts += s
    if not piece_parts:
        return verts, cap, line, draw, stop, origin
    piece, s, end = _kept_cuts(piece_parts, s_parts, d)
    if len(piece) == n:
        return verts, cap, line, draw, stop, origin
    verts = put_in(kin, verts, e, piece, s, end)
    return verts, cap[piece], line[piece], draw[piece], stop[piece] & end, origin[piece]


def put_in(kin, verts, e, piece, s, end) -> np.ndarray:
    """verts with points put in on its pieces (directions e): vertex j + 1 of the result at s[j]
    along piece[j], exactly the piece's end vertex where end[j]. A machine that keeps what it
    solved at vertices is told (`carry`: the tilting gondola's balance)."""
    new = verts[piece] + scaled(e[piece], s)
    new[end] = verts[1:][piece[end]]
    out = np.vstack((verts[:1], new))
    carry = getattr(kin, "carry", None)
    if carry is not None:
        carry(verts, out, piece, end)
    return out


def _rate_cuts(v_cord, k0, k1, d, cap) -> tuple[list, list]:
    """Equal parts where the rate limit changes by more than RATE_STEP along the piece: the
    pieces cut and where (lists of arrays). Each motor's |slope| runs one way along a piece
    (pieces are cut where it is zero), so its limit lies between its values at the two
    ends."""
    with np.errstate(divide="ignore"):
        m0 = v_cord / np.maximum(k0, 1e-9)
        m1 = v_cord / np.maximum(k1, 1e-9)
    lo = np.minimum(m0, m1)
    hi = np.minimum(np.maximum(m0, m1), cap)
    ratio = most(np.where(lo < cap, np.maximum(hi / lo, 1.0), 1.0))
    parts = np.where(ratio > 1.0 + RATE_STEP, np.ceil(np.log(ratio) / np.log1p(RATE_STEP)), 1.0)
    parts = np.minimum(parts, np.maximum(np.floor(d / RATE_PART_MM), 1.0)).astype(np.int64)
    parts = np.minimum(parts, MAX_PARTS)
    many = np.flatnonzero(parts > 1)
    if not len(many):
        return [], []
    c = parts[many] - 1
    piece = np.repeat(many, c)
    j = np.arange(len(piece)) - np.repeat(np.cumsum(c) - c, c) + 1
    return [piece], [d[piece] * j / parts[piece]]


def _sharp_cuts(acc, jump, k0, k1, d, cap, vcap, vr0, vr1, stop) -> tuple[list, list]:
    """Next to each sharp corner (the speed there at most v_hi, the corner taking
    CORNER_SHARE), the part the pen covers within NEAR_TAU x TAU_S of it: the pieces cut
    and where (lists of arrays)."""
    ds = np.minimum(d[1:], d[:-1])
    with np.errstate(divide="ignore", invalid="ignore"):
        v_tau = least(CORNER_SHARE * acc * TAU_S / jump)      # (inf where no jump)
        v_ds = least(np.sqrt(CORNER_SHARE * acc * ds / jump))
    v_hi = np.minimum(np.minimum(v_tau, v_ds), np.minimum(vcap[1:], vcap[:-1]))
    sharp = (v_hi * TAU_S < ds) & ~stop[:-1] & (most(jump) > 1e-6)
    # How far the pen may go within t of the corner, whatever the parts' own limits
    # come out as. The corner is an end of both parts next to it, so: the corner is
    # passed at most at v_tau (the jump alone over TAU at CORNER_SHARE); on each part
    # the speed stays within the cap and the rate limit at the corner, and the path
    # acceleration within acc / max(|slope at the corner|, MIN_SLOPE). Each part next
    # to the corner is then at least v_hi x TAU long: `_profile` sees a sharp corner
    # there too.
    t = NEAR_TAU * TAU_S
    v_c = np.minimum(v_tau, np.maximum(cap[1:], cap[:-1]))
    a_in = least(acc / np.maximum(k1[:, :-1], MIN_SLOPE))
    a_out = least(acc / np.maximum(k0[:, 1:], MIN_SLOPE))
    reach_in = np.minimum(v_c * t + 0.5 * a_in * t * t, np.minimum(cap[:-1], vr1[:-1]) * t)
    reach_out = np.minimum(v_c * t + 0.5 * a_out * t * t, np.minimum(cap[1:], vr0[1:]) * t)
    end_cut = sharp & (reach_in < 0.5 * d[:-1])
    start_cut = sharp & (reach_out < 0.5 * d[1:])
    i = np.flatnonzero(end_cut)
    o = np.flatnonzero(start_cut)
    return [i, o + 1], [d[i] - reach_in[i], reach_out[o]]


def _kept_cuts(piece_parts: list, s_parts: list, d: np.ndarray):
    """The cuts in order along the path, each piece's end included, without those that
    would leave a part shorter than MIN_PART_MM: piece, distance along it, is-its-end."""
    piece = np.concatenate(piece_parts + [np.arange(len(d))])
    s = np.concatenate(s_parts + [d])
    order = np.lexsort((s, piece))
    piece, s = piece[order], s[order]
    end = s == d[piece]
    prev = np.concatenate(([-1.0], s[:-1]))
    first = np.concatenate(([True], piece[1:] != piece[:-1]))
    prev[first] = 0.0
    good = end | ((s - prev > MIN_PART_MM) & (d[piece] - s > MIN_PART_MM))
    return piece[good], s[good], end[good]


def sharp_shares(jump, acc, k_in, k_out, d_in, d_out, cap_in, cap_out, vc, ds, far_in, far_out):
    """Per sharp corner, the share of the budget (one of SHARP_TRY) that passes it quickest: a
    lower share lowers the corner speed and leaves the pieces on either side more to brake
    and speed up with. Estimated as the time of the two pieces next to it, each ramping from
    the corner speed with what the corner leaves towards the highest speed it may reach (its
    cap, and the speed of the corner at its other end at the most that may take). jump,
    k_in, k_out: (M, corners); acc: (M, 1)."""
    c = SHARP_TRY[:, None]                                     # (S, 1)
    with np.errstate(divide="ignore", invalid="ignore"):
        per = least(acc * TAU_S / jump)                       # (inf where no jump)
        per_ds = least(np.sqrt(acc * ds / jump))
        v_c = np.minimum(np.minimum(c * per, np.sqrt(c) * per_ds), vc)       # (S, corners)
        used = np.minimum(np.maximum(v_c / per, (v_c / per_ds) ** 2), c)     # what it takes
    free = 1.0 - used
    vc2 = v_c * v_c
    t = 0.0
    for L, k, cap in ((d_in, k_in, np.minimum(cap_in, far_in)),
                      (d_out, k_out, np.minimum(cap_out, far_out))):
        a = free * least(acc / np.maximum(k, MIN_SLOPE))
        a2 = 2.0 * a
        v_top = np.maximum(np.minimum(np.sqrt(vc2 + a2 * L), cap), v_c)
        cruise = np.maximum(L - (v_top * v_top - vc2) / a2, 0.0)
        t = t + ((v_top - v_c) / a + cruise / np.maximum(v_top, 1e-300))
    return SHARP_TRY[np.argmin(t, axis=0)]
