"""The camera of a calibration photo: a pinhole with radial lens distortion looking at the wall.

The wall is the machine frame's plane (x right, y down, mm; the world's z points into the
wall), so a camera in front of the wall sees it without a mirror. A camera is nine numbers:

    rx ry rz   rotation vector (world -> camera)
    tx ty tz   translation (mm): camera = R world + t
    log_f      focal length in pixels, log
    k1 k2      radial distortion of the normalised coordinates: d = u (1 + k1 r^2 + k2 r^4)

and the principal point, fixed at the image centre (phones put it within a few pixels).
`project` maps wall points to pixels, `backproject` pixels to wall points (the undistortion
by fixed-point iteration), `homography` is the plane-to-image DLT that starts a fit and
`from_homography` the camera that starts it (Zhang's two constraints give f where the view
is oblique enough; else the guess).
"""

from __future__ import annotations

import numpy as np

N_PARAMS = 9
UNDISTORT_ITERATIONS = 20


def rotation(rvec) -> np.ndarray:
    """Rodrigues: the rotation matrix of a rotation vector."""
    r = np.asarray(rvec, dtype=float)
    th = float(np.linalg.norm(r))
    if th < 1e-12:
        k = np.array([[0, -r[2], r[1]], [r[2], 0, -r[0]], [-r[1], r[0], 0]])
        return np.eye(3) + k
    k = r / th
    kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(th) * kx + (1 - np.cos(th)) * kx @ kx


def rotation_vector(rot: np.ndarray) -> np.ndarray:
    """The inverse of `rotation` (angles below pi)."""
    c = np.clip((np.trace(rot) - 1) / 2, -1.0, 1.0)
    th = float(np.arccos(c))
    w = np.array([rot[2, 1] - rot[1, 2], rot[0, 2] - rot[2, 0], rot[1, 0] - rot[0, 1]])
    if th < 1e-9:
        return w / 2
    return w * th / (2 * np.sin(th))


def distort(u: np.ndarray, k1: float, k2: float) -> np.ndarray:
    r2 = np.sum(u * u, axis=-1, keepdims=True)
    return u * (1 + k1 * r2 + k2 * r2 * r2)


def undistort(d: np.ndarray, k1: float, k2: float) -> np.ndarray:
    """The normalised point u with distort(u) = d (fixed point; phones' k are small)."""
    u = np.array(d, dtype=float)
    for _ in range(UNDISTORT_ITERATIONS):
        r2 = np.sum(u * u, axis=-1, keepdims=True)
        u = d / (1 + k1 * r2 + k2 * r2 * r2)
    return u


def project(cam, centre, xy) -> np.ndarray:
    """Pixels (N, 2) of wall points xy (N, 2) in the machine frame."""
    cam = np.asarray(cam, dtype=float)
    xy = np.asarray(xy, dtype=float)
    rot = rotation(cam[:3])
    pc = xy @ rot[:, :2].T + cam[3:6]
    u = pc[:, :2] / pc[:, 2:3]
    return np.exp(cam[6]) * distort(u, cam[7], cam[8]) + np.asarray(centre, dtype=float)


def backproject(cam, centre, px) -> np.ndarray:
    """Wall points (machine frame) seen at pixels px (N, 2): the ray meets the wall."""
    cam = np.asarray(cam, dtype=float)
    rot = rotation(cam[:3])
    d = (np.asarray(px, dtype=float) - np.asarray(centre, dtype=float)) / np.exp(cam[6])
    u = undistort(d, cam[7], cam[8])
    ray = np.column_stack((u, np.ones(len(u)))) @ rot           # world directions (R^T u)
    origin = -rot.T @ cam[3:6]
    s = -origin[2] / ray[:, 2]
    return origin[:2] + s[:, None] * ray[:, :2]


def _normaliser(p: np.ndarray) -> np.ndarray:
    c = p.mean(axis=0)
    s = np.sqrt(2) / max(float(np.mean(np.hypot(*(p - c).T))), 1e-12)
    return np.array([[s, 0, -s * c[0]], [0, s, -s * c[1]], [0, 0, 1]])


def homography(src, dst) -> np.ndarray:
    """The 3 x 3 H with dst ~ H src (normalised DLT, least squares for 4 or more points)."""
    src, dst = np.asarray(src, dtype=float), np.asarray(dst, dtype=float)
    ts, td = _normaliser(src), _normaliser(dst)
    s = np.column_stack((src, np.ones(len(src)))) @ ts.T
    d = np.column_stack((dst, np.ones(len(dst)))) @ td.T
    z = np.zeros((len(s), 3))
    a = np.vstack((np.hstack((s, z, -d[:, :1] * s)), np.hstack((z, s, -d[:, 1:2] * s))))
    h = np.linalg.svd(a)[2][-1].reshape(3, 3)
    h = np.linalg.inv(td) @ h @ ts
    return h / h[2, 2]


def apply(h, pts) -> np.ndarray:
    p = np.column_stack((np.asarray(pts, dtype=float), np.ones(len(pts)))) @ np.asarray(h).T
    with np.errstate(divide="ignore", invalid="ignore"):
        return p[:, :2] / p[:, 2:3]


def focal_from_homography(h, centre) -> float | None:
    """f (px) from the two constraints of a rotation's first two columns, or None where the
    view is too straight on to tell it."""
    t = np.array([[1, 0, -centre[0]], [0, 1, -centre[1]], [0, 0, 1]])
    g = t @ h
    h1, h2 = g[:, 0], g[:, 1]
    a = np.array([h1[0] * h2[0] + h1[1] * h2[1], h1[0] ** 2 + h1[1] ** 2 - h2[0] ** 2 - h2[1] ** 2])
    b = np.array([h1[2] * h2[2], h1[2] ** 2 - h2[2] ** 2])
    if float(a @ a) == 0:
        return None
    w = -float(a @ b) / float(a @ a)
    if not w > 0:
        return None
    return 1 / np.sqrt(w)


def from_homography(h, centre, f: float) -> np.ndarray:
    """The camera (k1 = k2 = 0, focal length f) nearest the plane-to-image homography h."""
    kinv = np.array([[1 / f, 0, -centre[0] / f], [0, 1 / f, -centre[1] / f], [0, 0, 1]])
    a = kinv @ h
    lam = 2 / (np.linalg.norm(a[:, 0]) + np.linalg.norm(a[:, 1]))
    a = a * lam
    if a[2, 2] < 0:                                    # the wall is in front of the camera
        a = -a
    r = np.column_stack((a[:, 0], a[:, 1], np.cross(a[:, 0], a[:, 1])))
    u, _, vt = np.linalg.svd(r)
    rot = u @ np.diag([1, 1, np.linalg.det(u @ vt)]) @ vt
    return np.concatenate((rotation_vector(rot), a[:, 2], [np.log(f), 0.0, 0.0]))
