"""The improvement of a tour (`order`'s best): 2-opt (reversing a run of strokes, each drawn
the other way) and or-opt (moving a run of up to three strokes, either way round) within a
window of nearby tour positions, vectorised over all positions at once (every non-overlapping
improving move of a round is made, then only the positions near a change are looked at
again); and the seams of closed strokes that make the travel in and out shortest."""

from __future__ import annotations

import numpy as np

from vplotter.drawing.order_tour import Tour

WINDOW = 40           # tour positions looked at by 2-opt and or-opt


def _d(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.hypot(a[..., 0] - b[..., 0], a[..., 1] - b[..., 1])


def _context(tour: Tour):
    """entry, exit (n, 2); P (n+1, 2): the point before position k (start, then exits);
    N (n, 2): the entry after position k (NaN after the last)."""
    entry, exit_ = tour.ends()
    P = np.vstack([tour.start[None, :], exit_])
    N = np.vstack([entry[1:], np.full((1, 2), np.nan)])
    return entry, exit_, P, N


def _nd(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distance, 0 where a point is NaN (no next stroke; no start point in a free tour)."""
    return np.nan_to_num(_d(a, b), nan=0.0)


def _pick(gain: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> list[int]:
    """Candidates with positive gain, best first, whose position ranges lo..hi do not
    overlap (such moves are independent and can all be made at once)."""
    cand = np.flatnonzero(gain > 1e-9)
    if len(cand) == 0:
        return []
    cand = cand[np.lexsort((cand, -gain[cand]))]
    used = np.zeros(int(hi.max()) + 2, dtype=bool)
    out = []
    for c in cand.tolist():
        a, b = int(lo[c]), int(hi[c]) + 1
        if not used[a:b].any():
            used[a:b] = True
            out.append(c)
    return out


def two_opt(tour: Tour) -> float:
    """Reverse runs perm[i..j] (each stroke then drawn the other way) where that shortens the
    travel, j - i < WINDOW; all non-overlapping improving moves of a round at once."""
    n = len(tour.perm)
    saved = 0.0
    off = np.arange(WINDOW)
    first = int(tour.fixed_first)
    rows = np.arange(first, n)
    while len(rows):
        entry, exit_, P, N = _context(tour)
        i = rows[:, None]
        j = i + off[None, :]
        ok = j < n
        j = np.minimum(j, n - 1)
        old = _nd(P[i], entry[i]) + _nd(exit_[j], N[j])
        new = _nd(P[i], exit_[j]) + _nd(entry[i], N[j])
        gain = np.where(ok, old - new, -np.inf)
        best = np.argmax(gain, axis=1)
        g = gain[np.arange(len(rows)), best]
        moves = _pick(g, np.maximum(rows - 1, 0), rows + best + 1)
        active = np.zeros(n + 1, dtype=bool)
        for c in moves:
            a = int(rows[c])
            b = a + int(best[c]) + 1
            tour.perm[a:b] = tour.perm[a:b][::-1].copy()
            tour.rev[a:b] = ~tour.rev[a:b][::-1]
            saved += float(g[c])
            active[max(a - WINDOW, 0):b + 1] = True
        rows = np.flatnonzero(active[:n])
        rows = rows[rows >= first]
    return saved


def or_opt(tour: Tour) -> float:
    """Move a run of 1..3 strokes (either way round) to between two other positions at most
    WINDOW away, where that shortens the travel; non-overlapping moves of a round at once."""
    n = len(tour.perm)
    saved = 0.0
    for seg in (1, 2, 3):
        if n <= seg:
            break
        offs = np.concatenate([np.arange(-WINDOW, 0), np.arange(seg + 1, seg + 1 + WINDOW)])
        first = int(tour.fixed_first)
        i = np.arange(first, n - seg + 1)
        while len(i):
            entry, exit_, P, N = _context(tour)
            jj = i + seg - 1
            remove = _nd(P[i], entry[i]) + _nd(exit_[jj], N[jj]) - _nd(P[i], N[jj])
            k = i[:, None] + offs[None, :]
            ok = (k >= first) & (k <= n)
            k = np.clip(k, 0, n)
            a = P[k]
            b = np.vstack([entry, np.full((1, 2), np.nan)])[k]
            base = _nd(a, b)
            fwd = _nd(a, entry[i][:, None]) + _nd(exit_[jj][:, None], b) - base
            bwd = _nd(a, exit_[jj][:, None]) + _nd(entry[i][:, None], b) - base
            ins = np.where(ok, np.minimum(fwd, bwd), np.inf)
            m = np.argmin(ins, axis=1)
            rows = np.arange(len(i))
            g = remove - ins[rows, m]
            kk = k[rows, m]
            lo = np.maximum(np.minimum(kk - 1, i - 1), 0)
            hi = np.maximum(jj + 1, kk)
            moves = _pick(g, lo, hi)
            flip = bwd[rows, m] < fwd[rows, m]
            active = np.zeros(n + 1, dtype=bool)
            for c in moves:
                s = int(i[c])
                e, t = s + seg, int(kk[c])
                rp, rr = tour.perm[s:e].copy(), tour.rev[s:e].copy()
                if flip[c]:
                    rp, rr = rp[::-1], ~rr[::-1]
                if t < s:
                    tour.perm[t:e] = np.concatenate([rp, tour.perm[t:s]])
                    tour.rev[t:e] = np.concatenate([rr, tour.rev[t:s]])
                else:
                    tour.perm[s:t] = np.concatenate([tour.perm[e:t], rp])
                    tour.rev[s:t] = np.concatenate([tour.rev[e:t], rr])
                saved += float(g[c])
                active[max(min(s, t) - WINDOW - seg, 0):max(e, t) + WINDOW + 1] = True
            i = np.flatnonzero(active[:n - seg + 1])
            i = i[i >= first]
    return saved


def best_seams(tour: Tour) -> float:
    """Each closed stroke enters (and leaves) at the vertex nearest to the travel in and out."""
    saved = 0.0
    if not tour.closed.any():
        return saved
    entry, exit_ = tour.ends()
    n = len(tour.perm)
    for k in np.flatnonzero(tour.closed[tour.perm]).tolist():
        if k == 0 and tour.fixed_first:
            continue
        i = int(tour.perm[k])
        prev = tour.start if k == 0 else exit_[k - 1]
        q = tour.strokes[i].pts[:-1]
        cost = _nd(q, prev)
        if k + 1 < n:
            cost = cost + _d(q, entry[k + 1])
        v = int(np.argmin(cost))
        old = float(_nd(tour.first[i], prev))
        old += float(_d(tour.first[i], entry[k + 1])) if k + 1 < n else 0.0
        if cost[v] < old - 1e-12:
            saved += old - float(cost[v])
            tour.set_seam(i, v)
            entry[k] = exit_[k] = q[v]
    return saved
