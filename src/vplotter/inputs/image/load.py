"""Any image Pillow reads -> a `Picture`: the ink coverage wanted at each pixel.

What `load` does, in order:

1. opens the file lazily (the header only) and refuses what it cannot read in one line:
   missing, empty, not an image, more than `MAX_PIXELS` (a decompression bomb is refused from
   its header, before anything is allocated), truncated (when the pixels are decoded);
2. reduces it to the resolution the pen can show, about pen_mm / 2 per pixel at the size it
   is drawn (a 12 MP photo drawn 300 mm wide with a 0.5 mm pen: 1200 px wide), before any
   float work: JPEG decodes at 1/2, 1/4 or 1/8 scale (`Image.draft`), then an integer box
   `reduce` brings it to between 1 and 2 times that resolution, and the last step (a Lanczos
   resize) is done in linear light;
3. turns it upright (the EXIF orientation, the table of `ImageOps.exif_transpose`, applied
   after the reduction where it costs least);
4. takes every mode to luminance in LINEAR light: palette (with its transparency), L, LA,
   1, I;16 and I (16-bit: 0..65535), F (0..1, or 0..255 when its maximum is above 1), CMYK,
   YCbCr, RGB, RGBA; sRGB decoded, Y = 0.2126 R + 0.7152 G + 0.0722 B; transparency is
   composited on white paper in linear light (alpha is coverage: Y = a Y + (1 - a));
5. the tone options, in the perceptual (sRGB-encoded) domain v of that luminance, before it
   is linearised again: `invert` first (v -> 1 - v, an editor's "invert"), then
   `contrast` scales around mid grey and `brightness` shifts (v -> (v - 0.5) * contrast +
   0.5 + brightness, clipped to 0..1; brightness > 0 is lighter, less ink);
6. darkness = 1 - Y: the ink coverage that reproduces the luminance on white paper.

Pillow and numpy are imported inside the functions: `vplotter --help` imports neither.
"""

from __future__ import annotations

import math
import os

from vplotter.errors import InputError

MAX_PIXELS = 89_478_485        # Pillow's own warning limit (a 9,459 x 9,459 image): above it,
                               # refused
ORIENTATION = 0x0112           # the EXIF tag


def _fail(path, why: str) -> InputError:
    why = " ".join(str(why).split()) or "cannot read it"
    return InputError(f"{path}: error: {why}")


def _open(path):
    """The image, opened lazily (header only), and its EXIF orientation (1..8)."""
    import warnings

    from PIL import Image, UnidentifiedImageError

    try:
        st = os.stat(path)
    except FileNotFoundError:
        raise _fail(path, "no such file") from None
    except OSError as e:
        raise _fail(path, e.strerror or e) from None
    if os.path.isdir(path):
        raise _fail(path, "is a directory, not an image")
    if st.st_size == 0:
        raise _fail(path, "empty file")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error", Image.DecompressionBombWarning)
            im = Image.open(path)
    except (Image.DecompressionBombError, Image.DecompressionBombWarning):
        raise _fail(path, f"too many pixels (over {MAX_PIXELS:,}): a decompression bomb?") from None
    except UnidentifiedImageError:
        raise _fail(path,
                    "not an image Pillow can read (PNG, JPEG, WebP, BMP, TIFF, GIF)") from None
    except (OSError, ValueError, SyntaxError, EOFError, MemoryError) as e:
        raise _fail(path, f"cannot read the image: {e}") from None
    w, h = im.size
    if w <= 0 or h <= 0 or w * h > MAX_PIXELS:
        im.close()
        raise _fail(path, f"{w} x {h} pixels: too many or none (at most {MAX_PIXELS:,})")
    try:
        orient = int(im.getexif().get(ORIENTATION, 1))
    except Exception:                  # a broken EXIF block does not spoil the picture
        orient = 1
    return im, (orient if 1 <= orient <= 8 else 1)


def aspect(path) -> float:
    """Width / height of the image as it is shown (after its EXIF orientation); reads the
    header only."""
    im, orient = _open(path)
    try:
        w, h = im.size
    finally:
        im.close()
    return h / w if orient >= 5 else w / h


def _linear_lut(levels: int):
    import numpy as np

    v = np.arange(levels, dtype=np.float64) / (levels - 1)
    return srgb_decode(v).astype(np.float32)


def srgb_decode(v):
    """sRGB-encoded 0..1 -> linear light 0..1."""
    import numpy as np

    v = np.asarray(v)
    return np.where(v <= 0.04045, v / 12.92, ((v + 0.055) / 1.055) ** 2.4)


def srgb_encode(y):
    """Linear light 0..1 -> sRGB-encoded 0..1."""
    import numpy as np

    y = np.clip(np.asarray(y), 0.0, 1.0)
    return np.where(y <= 0.0031308, y * 12.92, 1.055 * np.power(y, 1 / 2.4) - 0.055)


def _canonical(im):
    """One of L, LA, RGB, RGBA (8 bits), I (16-bit values) or F, keeping transparency."""
    m = im.mode
    if m in ("L", "LA", "RGB", "RGBA", "F"):
        return im
    if m.startswith("I"):
        return im.convert("I") if m != "I" else im
    if m in ("1",):
        return im.convert("L")
    if m in ("P", "PA"):
        has_alpha = m == "PA" or "transparency" in im.info
        return im.convert("RGBA" if has_alpha else "RGB")
    if m in ("La", "RGBa"):                       # premultiplied
        return im.convert("RGBA" if m == "RGBa" else "LA")
    return im.convert("RGB")                      # CMYK, YCbCr, LAB, HSV, RGBX...


def _luminance(im):
    """(H, W) float32 linear luminance on white paper, from a canonical image."""
    import numpy as np

    m = im.mode
    a = np.asarray(im)
    if m == "I":
        y = srgb_decode(np.clip(a, 0, 65535).astype(np.float32) / np.float32(65535))
        return y.astype(np.float32)
    if m == "F":
        a = np.nan_to_num(a.astype(np.float32), nan=1.0, posinf=1.0, neginf=0.0)
        if a.size and float(a.max()) > 1.0:
            a = a / np.float32(255)
        return srgb_decode(np.clip(a, 0, 1)).astype(np.float32)
    lut = _linear_lut(256)
    if m in ("L", "LA"):
        g = a if m == "L" else a[..., 0]
        y = lut[g]
    else:
        y = (np.float32(0.2126) * lut[a[..., 0]] + np.float32(0.7152) * lut[a[..., 1]]
             + np.float32(0.0722) * lut[a[..., 2]])
    if m in ("LA", "RGBA"):
        alpha = a[..., -1].astype(np.float32) / np.float32(255)
        y = alpha * y + (1 - alpha)
    return y.astype(np.float32)


_TRANSPOSE = {2: "FLIP_LEFT_RIGHT", 3: "ROTATE_180", 4: "FLIP_TOP_BOTTOM", 5: "TRANSPOSE",
              6: "ROTATE_270", 7: "TRANSVERSE", 8: "ROTATE_90"}   # ImageOps.exif_transpose's


def target_px(width_mm: float, height_mm: float, pen_mm: float) -> tuple[int, int]:
    """Pixels (across, down) the pen can show at that size: pen_mm / 2 per pixel."""
    px = max(pen_mm, 1e-3) / 2
    return max(1, math.ceil(width_mm / px)), max(1, math.ceil(height_mm / px))


def _decoded(path, width_mm: float, height_mm: float, pen_mm: float):
    """(the image decoded, canonical, reduced to 1..2 x the pixels the pen shows and upright;
    the target size (across, down) in pixels)."""
    from PIL import Image

    if not (width_mm > 0 and height_mm > 0 and pen_mm > 0):
        raise _fail(path, f"size {width_mm} x {height_mm} mm, pen {pen_mm} mm: must be > 0")
    im, orient = _open(path)
    tw, th = target_px(width_mm, height_mm, pen_mm)
    if orient >= 5:                                   # stored on its side
        tw, th = th, tw
    try:
        try:
            im.seek(0)                                # GIF, TIFF: the first frame
        except EOFError:
            pass
        if im.format == "JPEG":
            im.draft(None, (tw, th))                  # 1/2, 1/4, 1/8 scale, still >= target
        im.load()
        im = _canonical(im)
        w, h = im.size
        k = min(w // tw, h // th)
        if k >= 2:                                    # box reduce, to 1..2 x target
            im = im.reduce(k)
        if orient != 1:
            im = im.transpose(getattr(Image.Transpose, _TRANSPOSE[orient]))
            tw, th = (th, tw) if orient >= 5 else (tw, th)
    except InputError:
        raise
    except MemoryError:
        raise _fail(path, "not enough memory to decode it") from None
    except Exception as e:                            # truncated, corrupt: Pillow's many kinds
        raise _fail(path, f"cannot decode the image: {e}") from None
    return im, tw, th


def _resized(y, tw: int, th: int):
    """A linear-light plane reduced to at most tw x th (Lanczos), clipped to 0..1."""
    import numpy as np
    from PIL import Image

    h, w = y.shape
    if w > tw or h > th:
        f = Image.fromarray(np.ascontiguousarray(y, dtype=np.float32))
        y = np.asarray(f.resize((min(w, tw), min(h, th)), Image.Resampling.LANCZOS),
                       dtype=np.float32)
        y = np.clip(y, 0, 1)
    return y


def _toned(y, contrast: float, brightness: float, invert: bool):
    """The tone options on linear light (in the sRGB-encoded domain, see the module's text)."""
    import numpy as np

    if invert or contrast != 1.0 or brightness != 0.0:
        v = srgb_encode(y)
        if invert:
            v = 1 - v
        v = np.clip((v - 0.5) * contrast + 0.5 + brightness, 0, 1)
        y = srgb_decode(v)
    return y


def load(path, width_mm: float, height_mm: float, pen_mm: float = 0.5, contrast: float = 1.0,
         brightness: float = 0.0, invert: bool = False):
    """Read an image into a `Picture` drawn width_mm x height_mm (the caller keeps the aspect,
    see `aspect`). Raises InputError (one line, starting with the path) for anything it
    cannot read."""
    import numpy as np

    from vplotter.inputs.image.picture import Picture

    im, tw, th = _decoded(path, width_mm, height_mm, pen_mm)
    y = _luminance(im)
    im.close()
    y = _toned(_resized(y, tw, th), contrast, brightness, invert)
    dark = np.array(np.clip(1 - y, 0, 1), dtype=np.float32, order="C")
    dark.flags.writeable = False                 # read-only: its blurs can be remembered
    return Picture(dark, float(width_mm), float(height_mm),
                   name=os.path.basename(str(path)))


def load_rgb(path, width_mm: float, height_mm: float, pen_mm: float = 0.5, contrast: float = 1.0,
             brightness: float = 0.0, invert: bool = False):
    """The image as red, green and blue in linear light on white paper ((3, H, W) float32,
    0..1), at the resolution `load` gives, the tone options applied to each channel (for
    --cmyk). A grey image has three equal channels."""
    import numpy as np

    im, tw, th = _decoded(path, width_mm, height_mm, pen_mm)
    m = im.mode
    if m in ("RGB", "RGBA"):
        a = np.asarray(im)
        lut = _linear_lut(256)
        planes = [lut[a[..., i]] for i in range(3)]
        if m == "RGBA":
            alpha = a[..., 3].astype(np.float32) / np.float32(255)
            planes = [alpha * p + (1 - alpha) for p in planes]
    else:
        planes = [_luminance(im)]                 # grey: one plane, resized and toned once
    im.close()
    out = [_toned(_resized(p, tw, th), contrast, brightness, invert) for p in planes]
    return np.stack(out * (3 // len(out))).astype(np.float32)


_BLURRED: list = []            # the last few (array, radius, blurred): a budget search blurs the
_KEEP = 4                     # same picture the same way for every density it tries


def blur(a, radius_px: float):
    """A separable box blur (twice: close to a Gaussian of sigma ~ radius / 1.4) of a 2-D
    array, edges clamped; radius below 0.5 px returns it unchanged. The result is read-only
    and remembered for the same array object and radius (the last _KEEP)."""
    import numpy as np

    r = int(round(radius_px))
    if r < 1:
        return a
    for src, rr, done in _BLURRED:
        if src is a and rr == r:
            return done
    out = np.asarray(a, dtype=np.float32)
    for _ in range(2):
        for axis in (0, 1):
            pad = [(0, 0), (0, 0)]
            pad[axis] = (r + 1, r)
            c = np.cumsum(np.pad(out, pad, mode="edge"), axis=axis, dtype=np.float64)
            n = out.shape[axis]
            hi = np.take(c, np.arange(2 * r + 1, 2 * r + 1 + n), axis=axis)
            lo = np.take(c, np.arange(0, n), axis=axis)
            out = ((hi - lo) / (2 * r + 1)).astype(np.float32)
    out.flags.writeable = False
    if isinstance(a, np.ndarray) and not a.flags.writeable and a.base is None:   # can't change
        _BLURRED.insert(0, (a, r, out))
        del _BLURRED[_KEEP:]
    return out
