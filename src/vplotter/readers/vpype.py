"""The reader of a vpype document (`*.vpype.npz`): what the vpype plugin (vplotter/vpype_plugin.py)
hands `draw`, `convert` and `estimate`. numpy only: vpype is not needed to read one.

The file is a numpy archive (no pickles): `points` (N, 2) in vpype's units, CSS pixels (1/96 in)
with y down; `starts` (M + 1) where each line begins in it; `layer` (M) each line's layer, an
index into the `meta` JSON's `layers` [{"id", "name", "color"}]; `meta` also has `page` (the
document's page size in pixels, or null). It is placed as vpype's `write` would write it as an
SVG and the SVG reader would read that: the page (else the tight bounds of the drawing, moved to
0, 0) centred on G-code X0 Y0, +Y up. Each layer is a pen: its name, else its colour, else its
number; the lines keep the order vpype left them in (the reader's order is `keep`)."""

from __future__ import annotations

from vplotter.readers.base import Reader

SUFFIX = ".vpype.npz"
FORMAT = "vplotter-vpype"
MM_PER_PX = 25.4 / 96.0


def load(path: str) -> dict:
    """The arrays and the meta of a document file (InputError if it is not one)."""
    import json
    import zipfile

    import numpy as np

    from vplotter.errors import InputError, unreadable

    try:
        with np.load(path, allow_pickle=False) as z:
            out = {k: z[k] for k in ("points", "starts", "layer", "meta")}
        meta = json.loads(str(out["meta"]))
    except OSError as e:
        raise unreadable(path, e) from None
    except (KeyError, ValueError, zipfile.BadZipFile, EOFError):
        raise InputError(f"{path}: error: not a vpype document written by vplotter's vpype "
                         f"plugin") from None
    if not isinstance(meta, dict) or meta.get("format") != FORMAT:
        raise InputError(f"{path}: error: not a vpype document written by vplotter's vpype "
                         f"plugin")
    out["meta"] = meta
    return out


def read(path: str, ctx):
    import numpy as np

    from vplotter.inputs.strokes import Drawing, Stroke

    doc = load(path)
    pts, starts, which = doc["points"], doc["starts"], doc["layer"]
    layers = doc["meta"].get("layers", [])
    page = doc["meta"].get("page")
    if page:
        origin, size = np.zeros(2), np.asarray(page, dtype=float)
    elif len(pts):                 # no page: the tight bounds, as vpype's write does
        origin = pts.min(axis=0)
        size = np.maximum(pts.max(axis=0) - origin, 1.0)
    else:
        origin, size = np.zeros(2), np.ones(2)
    w_mm, h_mm = size * MM_PER_PX
    mm = (pts - origin) * MM_PER_PX
    xy = np.column_stack((mm[:, 0] - w_mm / 2, h_mm / 2 - mm[:, 1]))
    strokes = []
    for k in range(len(starts) - 1):
        lay = layers[int(which[k])]
        pen = lay.get("name") or lay.get("color") or str(lay.get("id"))
        name = lay.get("name") or str(lay.get("id"))
        strokes.append(Stroke(xy[starts[k]:starts[k + 1]], k + 1, 0, layer=name,
                              src=f"layer {name}, line {k + 1}", pen=pen,
                              colour=lay.get("color")))
    wanted = ctx.layers
    if wanted:
        strokes = [s for s in strokes if s.layer in wanted]
    return Drawing(path, strokes, float(w_mm), float(h_mm),
                   layers=[{"id": str(lay.get("id")), "label": lay.get("name") or "",
                            "visible": True} for lay in layers])


def place(path: str, stroke, k: int) -> str:
    return f"{path}: {stroke.src}" if stroke.src else f"{path}: line {k + 1}"


READER = Reader("vpype", "vpype document", (SUFFIX,), read, place, options=("layer",),
                order="keep")
