"""The marks of one calibration photo, found, numbered and measured; the picture of them.

`locate` runs photo_marks (candidates on the reduced photo), photo_identify (which is which)
and photo_marks.centre (each centre at full resolution), and refuses a photo in which not
every mark is found, in one line that says what was (`found 11 of 16 marks: 4, 8, 12, 15
and 16 not found (outside the photo?)`). `draw_found` draws the marks found, numbered, over
the photo (and the missing ones where they should have been) for `-o found.png`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vplotter.calibration import photo_identify, photo_marks
from vplotter.calibration.photo_load import Photo
from vplotter.errors import InputError

FOUND_PX = 1600              # found.png's long side


@dataclass
class Located:
    px: dict[int, np.ndarray]          # mark id -> centre (full-resolution pixels)
    predicted: dict[int, np.ndarray]   # mark id -> where it should be (pixels)
    radius_px: float
    extra: int = 0                     # mark-like shapes that are no mark of the pattern
    error: str | None = None           # what was found, where not every mark was


def _listing(ids: list[int]) -> str:
    s = [str(k) for k in ids]
    return s[0] if len(s) == 1 else ", ".join(s[:-1]) + " and " + s[-1]


def _missing(photo: Photo, ids, located: Located) -> str:
    h, w = photo.full.shape
    miss = [k for k in ids if k not in located.px]
    out = [k for k in miss if not (0 <= located.predicted[k][0] < w
                                   and 0 <= located.predicted[k][1] < h)]
    why = ("outside the photo?" if len(out) == len(miss) else
           "hidden, smudged or outside the photo?" if out else "hidden, blurred or smudged?")
    more = (f"; and {located.extra} marks that are not in the pattern (a photo of another "
            f"pattern?)" if located.extra >= 2 else "")
    return (f"{photo.name}: error: found {len(located.px)} of {len(ids)} marks: "
            f"{_listing(miss)} not found ({why}){more}")


def locate(photo: Photo, ids: list[int], page_xy: np.ndarray) -> Located:
    """The marks of the pattern in the photo (`error` says what was found where not every
    mark was); an InputError where no pattern is seen at all."""
    cands = photo_marks.find(photo.small, photo.scale)
    num = photo_identify.number(
        cands, ids, page_xy,
        lambda which: photo_marks.rings(photo.small, photo.scale, cands, which)
    ) if len(cands.xy) else None
    # a few marks matched among many more mark-like shapes off the grid: a texture's holes
    # that happened to lie near a grid (a photo of noise), not a pattern partly hidden
    chance = num is not None and len(num.found) < len(ids) and num.extra > 2 * len(num.found)
    if num is None or len(num.found) < max(4, len(ids) // 2) or chance:
        what = ("nothing like a mark" if not len(cands.xy) else
                f"{len(cands.xy)} closed shapes, none of them the pattern's"
                if num is None or not num.found
                else f"{len(cands.xy)} closed shapes, only {len(num.found)} in the pattern's "
                     f"grid")
        raise InputError(f"{photo.name}: error: no calibration pattern found ({what}; mark 1 "
                         f"has two circles): is the whole pattern in the photo, and sharp?")
    radius = num.radius_px
    px = {}
    for k, i in num.found.items():                 # mark 1's outer circle: 5 mm, not 3
        c = photo_marks.centre(photo.full, cands.xy[i], 2 * radius if k == 1 else radius)
        if c is not None:
            px[k] = c
    located = Located(px, {k: num.predicted[j] for j, k in enumerate(ids)}, radius, num.extra)
    if len(px) < len(ids):
        located.error = _missing(photo, ids, located)
    return located


def draw_found(photo: Photo, located: Located, path, residual_mm: dict | None = None) -> None:
    """found.png: the photo (reduced), each mark found circled in green with its number
    above (and its residual in mm), each missing one in red where it should have been."""
    from PIL import Image, ImageDraw, ImageFont

    h, w = photo.full.shape
    k = max(1.0, max(w, h) / FOUND_PX)
    im = Image.fromarray(photo.full).convert("RGB")
    if k > 1:
        im = im.resize((round(w / k), round(h / k)), Image.Resampling.BILINEAR)
    d = ImageDraw.Draw(im)
    r = max(8.0, 4.0 * located.radius_px / k)
    try:
        font = ImageFont.load_default(size=max(12, round(im.size[0] / 80)))
    except (TypeError, OSError):          # an older Pillow, or one without FreeType
        font = ImageFont.load_default()
    for mark, p in located.predicted.items():
        found = mark in located.px
        x, y = (located.px[mark] if found else p) / k
        colour = (0, 170, 0) if found else (220, 0, 0)
        d.ellipse([x - r, y - r, x + r, y + r], outline=colour, width=2)
        label = str(mark) if found else f"{mark}?"
        if found and residual_mm and mark in residual_mm:
            label += f": {residual_mm[mark]:.2f} mm"
        box = d.textbbox((x - r, y - r - 3), label, font=font, anchor="ld")
        d.rectangle(box, fill=(255, 255, 255))
        d.text((x - r, y - r - 3), label, fill=colour, font=font, anchor="ld")
    try:
        im.save(path, "PNG")
    except (OSError, ValueError) as e:
        raise InputError(f"{path}: error: cannot write it: {e}") from None
