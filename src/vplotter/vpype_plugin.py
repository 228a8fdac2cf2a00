"""The vpype plugin: `vpype read in.svg linemerge linesort vplotter draw` (docs/vpype.md).

One vpype command, `vplotter ACTION [options]`, ACTION one of draw, convert, estimate: the
document as vpype left it is written as a `*.vpype.npz` document (readers/vpype.py reads it
back: each layer a pen, the lines in vpype's order, placed as its SVG would be) and handed to
`vplotter ACTION FILE` itself (cli.main), so that the pipeline, the lock, the journal, resume
and every message are draw's. A draw that moves the machine keeps its document in the state
directory, named by its content, so that `--resume` (here or `vplotter draw FILE --resume`)
and `--detach` find it; the others use a temporary one. Registered under the entry point group
`vpype.plugins` (pyproject.toml); vpype and click are imported only here.
"""

from __future__ import annotations

import hashlib
import io
import json
import os
import tempfile

import click
import numpy as np
import vpype as vp
import vpype_cli

from vplotter.readers.vpype import FORMAT, SUFFIX

KEEP = 20       # documents kept in the state directory for --resume (the newest)

ACTIONS = ("draw", "convert", "estimate")
ONLY = {"dry_run": "draw", "detach": "draw", "backend": "draw", "trace": "draw",
        "trust_position": "draw", "realtime": "draw", "resume": "draw", "force": "draw",
        "output": "convert"}


def document_bytes(document: vp.Document) -> bytes:
    """The document as readers/vpype.py reads it (an .npz archive, no pickles)."""
    points, starts, which, layers = [], [0], [], []
    for i, lid in enumerate(sorted(document.layers)):
        lc = document.layers[lid]
        name = lc.property(vp.METADATA_FIELD_NAME) if lc.property_exists(
            vp.METADATA_FIELD_NAME) else None
        color = lc.property(vp.METADATA_FIELD_COLOR) if lc.property_exists(
            vp.METADATA_FIELD_COLOR) else None
        if color is None:   # vpype's own colour for it (its viewer's, its `write`'s)
            color = vp.METADATA_DEFAULT_COLOR_SCHEME[i % len(vp.METADATA_DEFAULT_COLOR_SCHEME)]
        layers.append({"id": int(lid), "name": str(name) if name else None,
                       "color": vp.Color(color).as_rgb_hex()})
        for line in lc:
            if len(line) == 0:
                continue
            points.append(np.column_stack((line.real, line.imag)))
            starts.append(starts[-1] + len(line))
            which.append(i)
    meta = {"format": FORMAT, "version": 1, "layers": layers,
            "page": list(map(float, document.page_size)) if document.page_size else None}
    buf = io.BytesIO()
    np.savez(buf, points=np.concatenate(points) if points else np.zeros((0, 2)),
             starts=np.asarray(starts, dtype=np.int64), layer=np.asarray(which, dtype=np.int64),
             meta=np.asarray(json.dumps(meta)))
    return buf.getvalue()


def _stem(document: vp.Document) -> str:
    """The name of the file vpype read the document from (vp_source), else `vpype`."""
    field = vp.METADATA_FIELD_SOURCE
    sources = [document.metadata.get(field)] + [lc.property(field) for lc in
                                                document.layers.values()
                                                if lc.property_exists(field)]
    for src in sources:
        if src:
            stem = os.path.basename(str(src)).rsplit(".", 1)[0]
            if stem:
                return stem
    return "vpype"


def _kept(data: bytes, stem: str) -> str:
    """The document in the state directory, by content (a resume finds the same file)."""
    from vplotter.config import state_dir

    folder = state_dir() / "vpype"
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"{stem}-{hashlib.sha256(data).hexdigest()[:12]}{SUFFIX}"
    if not path.exists():
        tmp = path.with_name(path.name + ".part")
        tmp.write_bytes(data)
        os.replace(tmp, path)
    old = sorted(folder.glob(f"*{SUFFIX}"), key=lambda p: p.stat().st_mtime)[:-KEEP]
    for p in old:
        if p != path:
            p.unlink(missing_ok=True)
    return str(path)


def _argv(action: str, path: str, opts: dict) -> list[str]:
    """`vplotter --config C ACTION FILE [options]` from the click options."""
    argv = ["--config", opts.pop("config"), action, path]
    for name, value in opts.items():
        if value is None or value is False or value == ():
            continue
        if name in ONLY and ONLY[name] != action:
            raise click.UsageError(f"--{name.replace('_', '-')} is for `vplotter "
                                   f"{ONLY[name]}`, not `vplotter {action}`")
        flag = "--" + name.replace("_", "-")
        if value is True:
            argv.append(flag)
        elif isinstance(value, tuple):
            argv += [flag, *map(str, value)]
        else:
            argv += [flag, str(value)]
    if action == "convert" and "--output" not in argv:
        raise click.UsageError("vplotter convert needs -o OUT.ngc ('-' for standard output)")
    return argv


def run(document: vp.Document, action: str, opts: dict) -> int:
    """`vplotter ACTION` on the document: its exit status (0: done)."""
    from vplotter import cli

    data = document_bytes(document)
    stem = _stem(document)
    if action == "draw" and not opts.get("dry_run"):
        return cli.main(_argv(action, _kept(data, stem), opts))
    with tempfile.TemporaryDirectory(prefix="vplotter-vpype-") as tmp:
        path = os.path.join(tmp, stem + SUFFIX)
        with open(path, "wb") as f:
            f.write(data)
        return cli.main(_argv(action, path, opts))


def _options(f):
    """draw's options that apply to a vpype document (given to vplotter as they are, so that
    it checks them as its command line does)."""
    text = {"type": str, "default": None}
    specs = [
        (("-o", "--output"), {**text, "metavar": "OUT.ngc", "help": "convert: G-code file"}),
        (("--config",), {"type": str, "default": "config.toml", "metavar": "PATH",
                         "help": "machine configuration (default: ./config.toml)"}),
        (("--dry-run",), {"is_flag": True, "help": "draw: simulate, nothing moves"}),
        (("--detach",), {"is_flag": True, "help": "draw: in the background"}),
        (("--backend",), {**text, "help": "draw: lgpio, gpiozero, fake or serial"}),
        (("--trace",), {**text, "metavar": "OUT.csv", "help": "draw: every GPIO change"}),
        (("--trust-position",), {"is_flag": True, "help": "draw: after an unclean stop"}),
        (("--realtime",), {"is_flag": True, "help": "draw: the fake backend in real time"}),
        (("--resume",), {"is_flag": True, "help": "draw: go on where it was stopped"}),
        (("--force",), {"is_flag": True, "help": "draw: --resume whatever changed"}),
        (("--verbose",), {"is_flag": True, "help": "say more"}),
        (("--scale",), {**text, "metavar": "S", "help": "scale about the drawing's centre"}),
        (("--fit",), {"is_flag": True, "help": "the largest size inside the page, centred"}),
        (("--width",), {**text, "metavar": "MM", "help": "scale to MM wide"}),
        (("--height",), {**text, "metavar": "MM", "help": "scale to MM high"}),
        (("--rotate",), {**text, "metavar": "DEG", "help": "counter-clockwise, about the centre"}),
        (("--margin",), {**text, "metavar": "MM", "help": "inside the page edges"}),
        (("--align",), {**text, "help": "left, center or right"}),
        (("--valign",), {**text, "help": "top, middle or bottom"}),
        (("--offset",), {"type": (str, str), "default": None, "metavar": "X Y",
                         "help": "move by X Y mm, last"}),
        (("--order",), {**text, "help": "keep (default: vpype's order), greedy or best"}),
        (("--join",), {**text, "metavar": "MM", "help": "draw on across gaps up to MM"}),
        (("--pen-order",), {**text, "help": "as vplotter draw --pen-order"}),
        (("--refill-every",), {**text, "help": "as vplotter draw --refill-every"}),
        (("--pause-between-layers",), {"is_flag": True, "help": "wait for Enter after each"}),
    ]
    for decls, kw in reversed(specs):
        f = click.option(*decls, **kw)(f)
    return f


class _Command(click.Command):
    """A command of vpype's chain whose options may follow its ACTION (`vplotter draw --fit`):
    its words end at the next vpype command's name (vpype's chain stops a command's options
    at its first argument)."""

    def parse_args(self, ctx: click.Context, args: list[str]) -> list[str]:
        group = ctx.parent.command if ctx.parent is not None else None
        names = (set(group.list_commands(ctx.parent)) if isinstance(group, click.Group)
                 else set())
        valued = {d: (p.nargs if p.nargs > 0 else 1) for p in self.params
                  if isinstance(p, click.Option) and not p.is_flag for d in p.opts}
        k, cut = 0, len(args)
        while k < len(args):
            if k > 0 and args[k] in names:
                cut = k
                break
            k += 1 + valued.get(args[k], 0)
        ctx.allow_interspersed_args = True
        super().parse_args(ctx, args[:cut])
        ctx.args = [*ctx.args, *args[cut:]]
        return ctx.args


@click.command("vplotter", cls=_Command)
@click.argument("action", type=click.Choice(ACTIONS))
@_options
@vpype_cli.global_processor
def vplotter(document: vp.Document, action: str, **opts) -> vp.Document:
    """Draw, convert (-o OUT.ngc) or estimate the document with vplotter.

    Each layer is a pen (its name, else its colour, else its number), drawn in vplotter's pen
    order; the lines in the order vpype left them (--order best to reorder); placed as
    `vplotter draw` places an SVG, with the same placement options (--fit, --align, --offset,
    --rotate ...). Example: vpype read in.svg linemerge linesort vplotter draw --fit
    """
    code = run(document, action, opts)
    if code:
        raise SystemExit(code)
    return document


vplotter.help_group = "Output"
