"""Phone photos of a drawing on the simulated wall (tests/test_calibrate_photo.py and
bench/calibrate_photo.py).

The drawing is given as pen-down polylines in wall mm (+y up), as tracecheck decodes a trace
through the TRUE geometry (a polyline of one point is a dot). It is inked with a round pen of
`pen_mm` on paper tile by tile (20 mm tiles at 0.04 mm a pixel, only where there is ink,
each drawn PAD_MM larger so that its blur is whole at its edges), and seen through a pinhole
camera that looks at the drawing's centre from `distance_mm`, turned `yaw_deg` about the
vertical and `pitch_deg` about the horizontal, rolled `roll_deg`, with radial lens distortion
k1, k2 (the normalised point u is seen at u (1 + k1 r^2 + k2 r^4)),
its focal length chosen so the drawing spans `fill` of the frame. Every pixel is traced back
to the wall (the undistortion by fixed-point iteration, independent of vplotter's), the
ink tile sampled after a blur of the pixel's footprint. Then the light: a gradient across the
frame down to `1 - light` of full, a vignette, paper grey-white, the ink 15 % of the paper;
a lens blur (Gaussian, px), noise, 8 bits, JPEG (or PNG). `exif_orientation` 6 stores the
photo on its side with the tag that turns it upright, as a phone held upright does.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

TILE_MM, TILE_RES_MM, PAD_MM = 20.0, 0.04, 1.5


@dataclass(frozen=True)
class View:
    size: tuple[int, int] = (2000, 1500)     # the photo as shown (across, down), pixels
    yaw_deg: float = 0.0
    pitch_deg: float = 0.0
    roll_deg: float = 0.0
    distance_mm: float = 900.0
    fill: float = 0.85
    k1: float = 0.0
    k2: float = 0.0
    light: float = 0.2                       # the darkest corner: 1 - light of the brightest
    noise: float = 0.01
    blur_px: float = 0.7
    quality: int = 90                        # JPEG; 0: PNG
    exif_orientation: int = 1                # 1 upright, 6 stored on its side


def _rotation(view: View, eye: np.ndarray, target: np.ndarray) -> np.ndarray:
    z = (target - eye) / np.linalg.norm(target - eye)
    down = np.array([0.0, 1.0, 0.0])
    y = down - (down @ z) * z
    y /= np.linalg.norm(y)
    x = np.cross(y, z)
    rot = np.vstack((x, y, z))
    a = np.radians(view.roll_deg)
    roll = np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])
    return roll @ rot


class Camera:
    """World: x right, y DOWN, z into the wall (the wall is z = 0); wall mm have y up."""

    def __init__(self, view: View, polylines):
        pts = np.vstack(polylines)
        lo, hi = pts.min(axis=0), pts.max(axis=0)
        target = np.array([(lo[0] + hi[0]) / 2, -(lo[1] + hi[1]) / 2, 0.0])
        yaw, pitch = np.radians(view.yaw_deg), np.radians(view.pitch_deg)
        eye = target + view.distance_mm * np.array([np.sin(yaw) * np.cos(pitch), np.sin(pitch),
                                                    -np.cos(yaw) * np.cos(pitch)])
        self.view, self.rot = view, _rotation(view, eye, target)
        self.t = -self.rot @ eye
        self.f = 1.0
        self.centre = (np.array(view.size, dtype=float) - 1) / 2
        corners = np.array([[lo[0], lo[1]], [hi[0], lo[1]], [hi[0], hi[1]], [lo[0], hi[1]]])
        span = np.ptp(self.normalised(corners), axis=0)
        self.f = float(view.fill * min(view.size[0] / span[0], view.size[1] / span[1]))

    def normalised(self, wall):
        w = np.column_stack((wall[:, 0], -wall[:, 1], np.zeros(len(wall))))
        pc = w @ self.rot.T + self.t
        u = pc[:, :2] / pc[:, 2:3]
        r2 = np.sum(u * u, axis=1, keepdims=True)
        return u * (1 + self.view.k1 * r2 + self.view.k2 * r2 * r2)

    def pixels(self, wall) -> np.ndarray:
        """Where wall points (mm, y up) are seen (pixels of the photo as shown)."""
        return self.f * self.normalised(np.asarray(wall, dtype=float)) + self.centre

    def wall(self, px) -> np.ndarray:
        d = (np.asarray(px, dtype=float) - self.centre) / self.f
        u = d.copy()
        for _ in range(30):
            r2 = np.sum(u * u, axis=1, keepdims=True)
            u = d / (1 + self.view.k1 * r2 + self.view.k2 * r2 * r2)
        ray = np.column_stack((u, np.ones(len(u)))) @ self.rot
        eye = -self.rot.T @ self.t
        s = -eye[2] / ray[:, 2]
        p = eye[:2] + s[:, None] * ray[:, :2]
        return np.column_stack((p[:, 0], -p[:, 1]))


def _tile(polylines, x0: float, y0: float, pen_mm: float) -> np.ndarray:
    """Ink coverage 0..1 of the tile whose lower left corner is x0, y0, with PAD_MM round it
    (rows: y down; x0, y0 are the padded tile's)."""
    from PIL import Image, ImageDraw

    n = int(round((TILE_MM + 2 * PAD_MM) / TILE_RES_MM))
    im = Image.new("L", (n, n), 0)
    draw = ImageDraw.Draw(im)
    w = pen_mm / TILE_RES_MM
    for p in polylines:
        q = np.column_stack(((p[:, 0] - x0) / TILE_RES_MM,
                             (y0 + TILE_MM + 2 * PAD_MM - p[:, 1]) / TILE_RES_MM))
        if len(q) > 1:
            along = np.concatenate(([0.0], np.cumsum(np.hypot(*np.diff(q, axis=0).T))))
            keep = np.flatnonzero(np.diff(np.floor(along / 2.0), prepend=-1) > 0)
            q = q[np.unique(np.append(keep, len(q) - 1))]     # a point every 2 px (0.08 mm)
            draw.line([tuple(v) for v in q], fill=255, width=int(round(w)))
        for v in (q[0], q[-1]):
            draw.ellipse([v[0] - w / 2, v[1] - w / 2, v[0] + w / 2, v[1] + w / 2], fill=255)
    return np.asarray(im, dtype=np.float32) / 255


def _ink(cam: Camera, polylines, pen_mm: float) -> np.ndarray:
    from scipy import ndimage

    w, h = cam.view.size
    out = np.zeros((h, w), dtype=np.float32)
    pts = np.vstack(polylines)
    keys = {tuple(k) for k in np.floor(pts / TILE_MM).astype(int)}
    for kx, ky in sorted(keys):
        x0, y0 = kx * TILE_MM, ky * TILE_MM
        grow = pen_mm + PAD_MM
        lo, hi = np.array([x0, y0]) - grow, np.array([x0, y0]) + TILE_MM + grow
        near = [p for p in polylines
                if (p.max(axis=0) >= lo).all() and (p.min(axis=0) <= hi).all()]
        tile = _tile(near, x0 - PAD_MM, y0 - PAD_MM, pen_mm)
        corners = cam.pixels(np.array([[x0, y0], [x0 + TILE_MM, y0], [x0, y0 + TILE_MM],
                                       [x0 + TILE_MM, y0 + TILE_MM]]))
        a = np.clip(np.floor(corners.min(axis=0)).astype(int), 0, [w - 1, h - 1])
        b = np.clip(np.ceil(corners.max(axis=0)).astype(int) + 1, 0, [w, h])
        if (b <= a).any():
            continue
        footprint = TILE_MM / max(float(np.ptp(corners, axis=0).max()), 1e-9)
        tile = ndimage.gaussian_filter(tile, 0.5 * footprint / TILE_RES_MM)
        ys, xs = np.mgrid[a[1]:b[1], a[0]:b[0]]
        wall = cam.wall(np.column_stack((xs.ravel(), ys.ravel())))
        col = (wall[:, 0] - x0 + PAD_MM) / TILE_RES_MM
        row = (y0 + TILE_MM + PAD_MM - wall[:, 1]) / TILE_RES_MM
        v = ndimage.map_coordinates(tile, [row, col], order=1, mode="constant", cval=0.0)
        block = out[a[1]:b[1], a[0]:b[0]]
        np.maximum(block, v.reshape(block.shape).astype(np.float32), out=block)
    return out


def render(polylines, path, view: View = View(), pen_mm: float = 0.5, seed: int = 0) -> Camera:
    """Write the photo of the drawing to `path` (JPEG, or PNG when view.quality is 0); the
    camera gives where each wall point is seen in the photo as shown."""
    from PIL import Image
    from scipy import ndimage

    polylines = [np.asarray(p, dtype=float).reshape(-1, 2) for p in polylines]
    cam = Camera(view, polylines)
    w, h = view.size
    ink = _ink(cam, polylines, pen_mm)
    ys, xs = np.mgrid[0:h, 0:w].astype(np.float32)
    light = 1 - view.light * (0.6 * xs / w + 0.4 * ys / h)
    r2 = ((xs - w / 2) ** 2 + (ys - h / 2) ** 2) / (w * w / 4 + h * h / 4)
    light *= 1 - 0.15 * r2
    img = 0.92 * light * (1 - 0.85 * ink)
    if view.blur_px > 0:
        img = ndimage.gaussian_filter(img, view.blur_px)
    rng = np.random.default_rng(seed)
    img = img + rng.normal(0, view.noise, img.shape).astype(np.float32)
    grey = np.clip(img * 255 + 0.5, 0, 255).astype(np.uint8)
    rgb = np.stack((grey, grey, (grey * 0.96).astype(np.uint8)), axis=-1)
    im = Image.fromarray(rgb, "RGB")
    exif = Image.Exif()
    if view.exif_orientation == 6:
        im = im.transpose(Image.Transpose.ROTATE_90)
        exif[0x0112] = 6
    if view.quality:
        im.save(path, "JPEG", quality=view.quality, exif=exif.tobytes())
    else:
        im.save(path, "PNG", exif=exif.tobytes())
    return cam
