"""The wall fit: the machine's parameters from distances measured between drawn marks.

Each mark's dot was made at known step counts n (relative to the stored reference). On the
wall the motors had paid out q = ref + n * circumference / steps_per_rev, and the pen was at
forward(q) of the true machine. Distances between dots depend on the anchor distance, the
two cord lengths at the reference, both circumferences and the stretch, but not on where the
whole drawing sits (a rigid motion of the drawing is not observable from distances; the
model has none: its frame is the anchors and gravity). The gondola's cord spacing trades off
exactly against the anchor distance (the drawing depends on their difference only), so one of
the two is fitted and the other kept. The pen's height below the cords only moves the whole
drawing and is kept. The gondola's centre of mass (mass_below_pen_mm: how far the gondola
tilts) can be fitted too (names(..., fit_mass=True)); mass_told() says whether the
measurements tell it.

Least squares by Levenberg-Marquardt (numpy only: no SciPy on a Pi Zero), Jacobian by
central differences; the uncertainty is the usual s^2 (J^T J)^-1. Measurements that do not
fit (typos, swapped rows) are taken out one at a time while one stands out.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from vplotter.kinematics.vplotter import TwoCord

GROSS_MM, GROSS_SHARE = 20.0, 0.05    # off the config's own prediction by more: a typo
OUTLIER_SIGMAS, OUTLIER_MIN_MM = 4.0, 1.0
MASS_START_MM = 30.0    # where a fit of the centre of mass starts when the config has none
MASS_SHARE = 0.25       # its uncertainty above this share of its arm: the data cannot tell
RMS_MAX_MM = 1.5        # a tape measure does better: the measurements do not fit together


@dataclass(frozen=True)
class Machine:
    """What decides where a dot lands (machine frame, mm)."""

    anchor_distance_mm: float
    ref_left_mm: float              # motor coordinates at step count 0 (the stored reference)
    ref_right_mm: float
    left_circumference_mm: float
    right_circumference_mm: float
    stretch: float
    cord_spacing_mm: float
    pen_below_mm: float
    steps_per_rev: int
    # the gondola's centre of mass below the pen (None: the gondola stays level)
    mass_below_pen_mm: float | None = None
    # the cords' mass per mm over the gondola's (their sag; kept, not fitted: 0 straight cords)
    sag_per_mm: float = 0.0

    def kin(self, origin=(0.0, 0.0)) -> TwoCord:
        return TwoCord(self.anchor_distance_mm, origin[0], origin[1], self.cord_spacing_mm,
                       self.pen_below_mm, self.stretch,
                       mass_below_pen_mm=self.mass_below_pen_mm, sag_per_mm=self.sag_per_mm)

    def cords(self, steps) -> np.ndarray:
        n = np.asarray(steps, dtype=float)
        return (np.array([self.ref_left_mm, self.ref_right_mm])
                + n * np.array([self.left_circumference_mm, self.right_circumference_mm])
                / self.steps_per_rev)

    def pen(self, steps) -> np.ndarray:
        """Machine-frame pen positions at these step counts."""
        return self.kin().forward(self.cords(steps))

    def steps_per_unit(self) -> tuple[float, float]:
        return (self.steps_per_rev / self.left_circumference_mm,
                self.steps_per_rev / self.right_circumference_mm)


def names(fit_spacing: bool, fit_mass: bool = False) -> tuple[str, ...]:
    """The parameters a fit adjusts (fields of Machine); `fit_mass`: the gondola's centre of
    mass too (mass_below_pen_mm; fit() starts a Machine without one at MASS_START_MM)."""
    first = "cord_spacing_mm" if fit_spacing else "anchor_distance_mm"
    return (first, "ref_left_mm", "ref_right_mm", "left_circumference_mm",
            "right_circumference_mm", "stretch") + (("mass_below_pen_mm",) if fit_mass else ())


def min_pairs(n_params: int) -> int:
    """Measured pairs needed: twice the parameters, so that a bad one shows."""
    return 2 * n_params


@dataclass
class Result:
    machine: Machine
    names: tuple[str, ...]
    sigma: np.ndarray               # uncertainty of each fitted parameter
    cov: np.ndarray
    residual_mm: np.ndarray         # model - measured, for every measured pair
    used: np.ndarray                # bool, pairs in the fit
    rms_mm: float


def _vector(m: Machine, keys) -> np.ndarray:
    return np.array([getattr(m, k) for k in keys], dtype=float)


def _with(m: Machine, keys, x) -> Machine:
    return replace(m, **{k: float(v) for k, v in zip(keys, x)})


def predicted(m: Machine, steps: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distances between the dots of marks a and b (indices into steps)."""
    p = m.pen(steps)
    return np.hypot(*(p[a] - p[b]).T)


def _lm(m0: Machine, keys, steps, a, b, dist):
    x = _vector(m0, keys)

    def res(x_):
        return predicted(_with(m0, keys, x_), steps, a, b) - dist

    def jac(x_):
        cols = []
        for j in range(len(x_)):
            h = 1e-6 * max(abs(x_[j]), 1.0)
            up, dn = x_.copy(), x_.copy()
            up[j] += h
            dn[j] -= h
            cols.append((res(up) - res(dn)) / (2 * h))
        return np.column_stack(cols)

    lam = 1e-3
    r = res(x)
    cost = float(r @ r)
    for _ in range(200):
        J = jac(x)
        A = J.T @ J
        g = J.T @ r
        diag = np.maximum(np.diag(A), 1e-12)
        improved = False
        while lam < 1e12:
            try:
                delta = np.linalg.solve(A + lam * np.diag(diag), -g)
            except np.linalg.LinAlgError:
                lam *= 10
                continue
            xn = x + delta
            rn = res(xn)
            cn = float(rn @ rn)
            if np.isfinite(cn) and cn <= cost:
                small = cost - cn <= 1e-12 * (1 + cost)
                x, r, cost = xn, rn, cn
                lam = max(lam / 3, 1e-9)
                improved = True
                break
            lam *= 4
        if not improved or small or np.all(np.abs(delta) <= 1e-10 * (np.abs(x) + 1e-6)):
            break
    J = jac(x)
    return x, r, J


def fit(m0: Machine, steps: np.ndarray, a: np.ndarray, b: np.ndarray, dist: np.ndarray,
        fit_spacing: bool = False, fit_mass: bool = False) -> tuple[Result, list[int]]:
    """Fit the parameters to the measured distances. Returns the result and the indices of
    the pairs left out as outliers (worst first)."""
    keys = names(fit_spacing, fit_mass)
    if fit_mass and m0.mass_below_pen_mm is None:
        m0 = replace(m0, mass_below_pen_mm=MASS_START_MM)
    # gross errors (a typo 1234 for 123.4, swapped rows): far off what the config predicts;
    # they may come back once the fit shows that they agree with it
    nominal = predicted(m0, steps, a, b)
    maybe = np.abs(nominal - dist) > GROSS_MM + GROSS_SHARE * dist
    used = ~maybe
    x, J = _vector(m0, keys), None
    for _ in range(2 * len(dist) + 2):
        if used.sum() < len(keys) + 2:
            break
        x, _, J = _lm(m0, keys, steps, a[used], b[used], dist[used])
        r_all = predicted(_with(m0, keys, x), steps, a, b) - dist
        r_used = r_all[used]
        scale = max(1.4826 * float(np.median(np.abs(r_used))) * np.sqrt(
            len(r_used) / max(len(r_used) - len(keys), 1)), 0.1)
        limit = max(OUTLIER_SIGMAS * scale, OUTLIER_MIN_MM)
        back = maybe & ~used & (np.abs(r_all) <= limit)
        if back.any():
            used |= back
            maybe &= ~back
            continue
        worst = int(np.argmax(np.where(used, np.abs(r_all), -1.0)))
        if abs(r_all[worst]) > limit:
            used[worst] = False
            continue
        break
    m = _with(m0, keys, x)
    r_all = predicted(m, steps, a, b) - dist
    outliers = [int(k) for k in np.flatnonzero(~used)[np.argsort(-np.abs(r_all[~used]))]]
    dof = max(int(used.sum()) - len(keys), 1)
    s2 = float(r_all[used] @ r_all[used]) / dof
    if J is not None:
        cov = s2 * np.linalg.pinv(J.T @ J)
    else:
        cov = np.full((len(keys), len(keys)), np.nan)
    res = Result(m, keys, np.sqrt(np.abs(np.diag(cov))), cov, r_all, used,
                 float(np.sqrt(np.mean(r_all[used] ** 2))) if used.any() else float("nan"))
    return res, outliers


def mass_told(res: Result) -> bool:
    """Whether the measurements tell where the gondola's centre of mass is: its uncertainty
    below MASS_SHARE of its distance from the cords' line (beyond, the gondola barely tilts
    or the fit trades the tilt off against the other parameters), and a gondola that hangs."""
    m = res.machine
    k = res.names.index("mass_below_pen_mm")
    arm = m.mass_below_pen_mm + m.pen_below_mm
    # no uncertainty at all: the distances do not depend on it (the pen where the cords meet)
    sigma = res.sigma[k]
    return bool(np.isfinite(sigma) and 0 < sigma <= MASS_SHARE * arm and arm > 0)


def mass_untold(res: Result, kept: float | None) -> str:
    """The line that says so, and what is kept."""
    k = res.names.index("mass_below_pen_mm")
    keep = ("kept unset (the gondola stays level)" if kept is None
            else f"kept at {kept:g} mm")
    return (f"note: the measurements cannot tell where the gondola's centre of mass is "
            f"(mass_below_pen_mm {res.machine.mass_below_pen_mm:.1f} ± {res.sigma[k]:.1f} mm): "
            f"{keep}; measure the gondola's balance point instead")


def line_bend_mm(believed: Machine, true: Machine, origin, a_gcode, b_gcode) -> float:
    """How far from straight a line from a to b (G-code mm) lands when the machine believes
    `believed` but is `true`: the largest distance of the drawn curve from the straight line
    through its ends (so shifts and scale do not count, only the bending)."""
    t = np.linspace(0.0, 1.0, 201)[:, None]
    g = np.asarray(a_gcode, dtype=float) * (1 - t) + np.asarray(b_gcode, dtype=float) * t
    kin_b = believed.kin(origin)
    q = kin_b.inverse(kin_b.to_machine(g))
    steps = (q - [believed.ref_left_mm, believed.ref_right_mm]) * believed.steps_per_unit()
    p = true.pen(steps)
    d = p[-1] - p[0]
    normal = np.array([-d[1], d[0]]) / np.hypot(*d)
    return float(np.abs((p - p[0]) @ normal).max())
