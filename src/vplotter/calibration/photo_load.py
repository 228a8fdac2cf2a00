"""A calibration photo from a file: grey, upright, at full resolution and reduced for finding.

JPEG, PNG and what else Pillow reads; HEIC and HEIF when pillow-heif is installed (imported
only for such a file; a one-line hint when it is not). The EXIF orientation is applied, the
colours go to luma (8 bits kept: a 12 MP photo is 12 MB), and the focal length in 35 mm terms,
when the phone wrote it, gives the camera's first guess. The marks are found on a copy reduced
by a whole factor to at most about DETECT_PX on the long side and measured on the full one.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vplotter.errors import InputError

DETECT_PX = 2000
MIN_PIXELS = 1_000_000
EXIF_IFD, FOCAL_35 = 0x8769, 0xA405
DIAGONAL_35_MM = 43.27


@dataclass
class Photo:
    name: str
    full: np.ndarray               # uint8 (rows, cols), upright
    small: np.ndarray              # float32 0..1, reduced by `scale`
    scale: int
    focal_px: float                # the first guess of the focal length

    @property
    def centre(self) -> tuple[float, float]:
        h, w = self.full.shape
        return ((w - 1) / 2, (h - 1) / 2)


def _heif(path: Path) -> None:
    if path.suffix.lower() not in (".heic", ".heif"):
        return
    try:
        import pillow_heif
    except ImportError:
        raise InputError(f"{path}: error: a HEIC photo needs pillow-heif (pip install "
                         f"pillow-heif), or save the photo as JPEG") from None
    pillow_heif.register_heif_opener()


def _focal(im, diagonal_px: float) -> float:
    """The focal length in pixels from EXIF (35 mm equivalent), else a phone's usual 26 mm."""
    try:
        f35 = float(im.getexif().get_ifd(EXIF_IFD).get(FOCAL_35, 0) or 0)
    except Exception:                  # a broken EXIF block does not spoil the photo
        f35 = 0.0
    if not 10 <= f35 <= 300:
        f35 = 26.0
    return f35 / DIAGONAL_35_MM * diagonal_px


def load(path: str | Path) -> Photo:
    from PIL import Image

    from vplotter.inputs.image.load import _TRANSPOSE, _open

    p = Path(path)
    _heif(p)
    im, orient = _open(p)
    try:
        if im.format == "JPEG":
            im.draft("L", im.size)
        im = im.convert("L")
        if orient != 1:
            im = im.transpose(getattr(Image.Transpose, _TRANSPOSE[orient]))
    except (OSError, ValueError, SyntaxError, EOFError) as e:
        raise InputError(f"{p}: error: cannot read the image: {' '.join(str(e).split())}") from None
    w, h = im.size
    if w * h < MIN_PIXELS:
        raise InputError(f"{p}: error: {w} x {h} pixels is too small to find the marks in "
                         f"(take the photo at 2 megapixels or more)")
    k = max(1, round(max(w, h) / DETECT_PX))
    small = im.reduce(k) if k > 1 else im
    full = np.asarray(im, dtype=np.uint8)
    small_a = np.asarray(small, dtype=np.float32) / np.float32(255)
    return Photo(str(p), full, small_a, k, _focal(im, math.hypot(w, h)))
