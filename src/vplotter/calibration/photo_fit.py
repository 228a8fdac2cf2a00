"""The joint fit of `calibrate photo`: the machine and every photo's camera together.

Each mark's dot was made at known step counts; the machine puts it at m.pen(steps) on the
wall (machine frame). Each photo's camera (photo_camera: pose, focal length, k1, k2) sees the
mark at a measured pixel; traced back to the wall, that pixel is where this camera says the
dot is. The residuals are those differences in mm on the wall (SIGMA_MARK_MM each), and
every tape-measured distance between two dots against the machine's (SIGMA_TAPE_MM): the
photos give the shape, no photo gives the size (a machine twice as large seen from twice as
far looks the same), the tape does. Where the drawing sits and how it is turned on the wall
is in the cameras' poses. Perspective, lens and machine are fitted at once (one after the
other, the camera would take up part of the machine's errors): scipy's Levenberg-Marquardt,
scaled by the Jacobian. A mark standing out of the fit (a number's hole taken for it) is left
out, the worst first, while one stands out.

The machine's parameters are a tuple of field names of fit.Machine (`dataclasses.replace`),
so whatever `calibrate fit` fits, this fits too.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from vplotter.calibration import photo_camera as camera
from vplotter.calibration.fit import Machine

SIGMA_MARK_MM = 0.1         # a mark's centre in a phone photo
SIGMA_TAPE_MM = 0.3         # a tape measure
OUTLIER_SIGMAS, OUTLIER_MIN_MM = 5.0, 0.5
MOST_LEFT_OUT = 3
MOST_EVALUATIONS = 40       # per parameter and solve: a fit that good data gives in fewer
FTOL = 1e-6                 # a step that lowers the cost by less than this share ends a solve


@dataclass
class Seen:
    """One photo's marks: indices into the pattern's marks, and where they are (pixels)."""
    name: str
    marks: np.ndarray
    px: np.ndarray
    centre: tuple[float, float]
    focal_px: float


@dataclass
class Joint:
    machine: Machine
    names: tuple[str, ...]
    sigma: np.ndarray
    cov: np.ndarray
    cameras: list[np.ndarray]
    residual_mm: list[np.ndarray]     # per photo: (n, 2) wall mm, traced back - machine
    used: list[np.ndarray]            # per photo: bool, marks in the fit
    tape_mm: np.ndarray               # machine - measured, per tape distance
    rms_mm: float


def start_camera(m: Machine, steps: np.ndarray, seen: Seen) -> np.ndarray:
    wall = m.pen(steps[seen.marks])
    h = camera.homography(wall, seen.px)
    f = camera.focal_from_homography(h, seen.centre)
    if f is None or not 0.33 * seen.focal_px <= f <= 3 * seen.focal_px:
        f = seen.focal_px
    return camera.from_homography(h, seen.centre, f)


def _with(m: Machine, keys, x) -> Machine:
    return replace(m, **{k: float(v) for k, v in zip(keys, x)})


def _residuals(x, m0, keys, steps, photos, used, tapes):
    nk = len(keys)
    m = _with(m0, keys, x[:nk])
    pen = m.pen(steps)
    out = []
    for i, s in enumerate(photos):
        cam = x[nk + camera.N_PARAMS * i: nk + camera.N_PARAMS * (i + 1)]
        wall = camera.backproject(cam, s.centre, s.px[used[i]])
        out.append(((wall - pen[s.marks[used[i]]]) / SIGMA_MARK_MM).ravel())
    if len(tapes):
        a, b, mm = tapes[:, 0].astype(int), tapes[:, 1].astype(int), tapes[:, 2]
        out.append((np.hypot(*(pen[a] - pen[b]).T) - mm) / SIGMA_TAPE_MM)
    # a machine that cannot put the pen there (a gondola tipped over): a step not taken
    return np.nan_to_num(np.concatenate(out), nan=1e6, posinf=1e6, neginf=-1e6)


def _solve(m0, keys, steps, photos, used, tapes, x0, most=MOST_EVALUATIONS):
    from scipy.optimize import least_squares

    sol = least_squares(_residuals, x0, args=(m0, keys, steps, photos, used, tapes),
                        method="lm", x_scale="jac", diff_step=1e-5, ftol=FTOL,
                        max_nfev=most * (len(x0) + 1))
    return sol


def fit(m0: Machine, keys: tuple[str, ...], steps: np.ndarray, photos: list[Seen],
        tapes: np.ndarray, most: int = MOST_EVALUATIONS) -> Joint:
    """tapes: rows (index a, index b, mm). The marks left out have used False; `most`:
    evaluations per parameter and solve."""
    nk = len(keys)
    x = np.concatenate([[getattr(m0, k) for k in keys]]
                       + [start_camera(m0, steps, s) for s in photos]).astype(float)
    used = [np.ones(len(s.marks), dtype=bool) for s in photos]
    for _ in range(MOST_LEFT_OUT + 1):
        sol = _solve(m0, keys, steps, photos, used, tapes, x, most)
        x = sol.x
        res = _wall_residuals(x, m0, keys, steps, photos)
        dist = [np.hypot(*r.T) for r in res]
        kept = np.concatenate([d[u] for d, u in zip(dist, used)])
        limit = max(OUTLIER_SIGMAS * 1.4826 * float(np.median(kept)), OUTLIER_MIN_MM)
        worst = max(((float(np.max(np.where(u, d, -1))), i) for i, (d, u)
                     in enumerate(zip(dist, used))))
        if worst[0] <= limit or used[worst[1]].sum() <= 6:
            break
        used[worst[1]][int(np.argmax(np.where(used[worst[1]], dist[worst[1]], -1)))] = False
    m = _with(m0, keys, x[:nk])
    jac = sol.jac
    dof = max(len(sol.fun) - len(x), 1)
    s2 = 2 * float(sol.cost) / dof
    cov = s2 * np.linalg.pinv(jac.T @ jac)[:nk, :nk]
    pen = m.pen(steps)
    tape_mm = (np.hypot(*(pen[tapes[:, 0].astype(int)] - pen[tapes[:, 1].astype(int)]).T)
               - tapes[:, 2]) if len(tapes) else np.zeros(0)
    kept = np.concatenate([np.hypot(*r[u].T) for r, u in zip(res, used)])
    cams = [x[nk + camera.N_PARAMS * i: nk + camera.N_PARAMS * (i + 1)]
            for i in range(len(photos))]
    return Joint(m, keys, np.sqrt(np.abs(np.diag(cov))), cov, cams, res, used, tape_mm,
                 float(np.sqrt(np.mean(kept ** 2))))


def _wall_residuals(x, m0, keys, steps, photos) -> list[np.ndarray]:
    nk = len(keys)
    pen = _with(m0, keys, x[:nk]).pen(steps)
    out = []
    for i, s in enumerate(photos):
        cam = x[nk + camera.N_PARAMS * i: nk + camera.N_PARAMS * (i + 1)]
        out.append(camera.backproject(cam, s.centre, s.px) - pen[s.marks])
    return out
