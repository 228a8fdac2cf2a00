"""`--style auto`: how well its quick ranking picks, and what each stage costs.

For every picture in a folder and each budget (1 h, 3 h), 300 mm wide on ./config.toml,
`vplotter convert --style auto` is run in this process with every style finished (its MARGIN
and FINISHED opened up; in one process, `photo_fork.WORKERS` = 1): per style the CPU time of
its budget's search, of its quick score (`photo_curve.quick_score`) and of its finish
(`photo.finished`: the curves fitted to the budget, the final order), the quick score and
the finished drawing's own score (the converter's measure, `inputs/image/score.py`). Then
the styles `--style auto` finishes with
its own MARGIN, FINISHED and ALWAYS, the one it keeps, and how far that is from the best
finished style; the same for other settings (`--policies`).

Run (from the repository root, in vplotter's venv; the pictures of `bench.photo_tone --make`):
    python -m bench.photo_auto DIR [--budgets 1h,3h] [--only NAME,...] [--json FILE]
"""

from __future__ import annotations

import argparse
import json
import os
import time

from bench import ROOT
from bench.photo_tone import SUFFIXES


def one(path: str, budget: str, config: str) -> dict:
    """{style: {search_s, quick_s, finish_s, quick, final}} of one --style auto run, every
    style finished."""
    from vplotter.cli import main
    from vplotter.drawing import photo, photo_auto, photo_curve, photo_fork

    rec: dict = {}
    saved = (photo_auto.FINISHED, photo_auto.MARGIN, photo.searched, photo.finished,
             photo_curve.quick_score, photo_fork.WORKERS)
    _, _, searched, finished, quick_score, _ = saved

    def timed(fn, key, name_of):
        def run(s, *a, **k):
            t0 = time.process_time()
            out = fn(s, *a, **k)
            rec.setdefault(name_of(s), {})[key] = time.process_time() - t0
            if key == "quick_s":
                rec[name_of(s)]["quick"], rec[name_of(s)]["bound"] = out
            if key == "finish_s":
                rec[name_of(s)]["final"] = photo_auto.tone_score(
                    out[2], (s.d.picture, s.d.layers, s.d.inks), s.d.opts.pen_mm)
            return out
        return run

    photo_auto.FINISHED, photo_auto.MARGIN = 99, 1.0
    photo_fork.WORKERS = 1              # one process: every style's figures recorded here
    photo.searched = timed(searched, "search_s", lambda d: photo_auto.name(d.opts))
    photo.finished = timed(finished, "finish_s", lambda s: photo_auto.name(s.d.opts))
    photo_curve.quick_score = timed(quick_score, "quick_s", lambda s: photo_auto.name(s.d.opts))
    try:
        out = os.path.join(os.environ.get("TMPDIR", "/tmp"), "bench-photo-auto.ngc")
        code = main(["--config", config, "convert", path, "-o", out, "--style", "auto",
                     "--width", "300", "--max-time", budget])
        if code:
            raise RuntimeError(f"convert {path} --style auto failed")
    finally:
        (photo_auto.FINISHED, photo_auto.MARGIN, photo.searched, photo.finished,
         photo_curve.quick_score, photo_fork.WORKERS) = saved
    return rec


def pick(styles: dict, finished: int, margin: float, always: tuple) -> tuple[list, str]:
    """(the styles finished, the one kept) under these settings, as `photo_auto.auto`."""
    ranked = sorted(styles, key=lambda s: -styles[s]["quick"])
    top = styles[ranked[0]]["quick"]
    rest = sorted((s for s in ranked[1:] if s not in always and styles[s]["bound"] >= top -
                   margin), key=lambda s: -styles[s]["bound"])
    done = [s for s in ranked if s in ranked[:1] + rest[:finished - 1] or s in always]
    return done, max(done, key=lambda s: styles[s]["final"])


def main() -> None:
    from vplotter.drawing import photo_auto

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("folder")
    ap.add_argument("--budgets", default="1h,3h")
    ap.add_argument("--only", default="", help="comma-separated picture names (no suffix)")
    ap.add_argument("--config", default=os.path.join(ROOT, "config.toml"))
    ap.add_argument("--json", metavar="FILE", help="also write every figure there")
    args = ap.parse_args()
    pics = sorted(os.path.join(args.folder, f) for f in os.listdir(args.folder)
                  if f.lower().endswith(SUFFIXES))
    if args.only:
        keep = set(args.only.split(","))
        pics = [p for p in pics if os.path.splitext(os.path.basename(p))[0] in keep]
    ours = (photo_auto.FINISHED, photo_auto.MARGIN, photo_auto.ALWAYS)
    runs = []
    for b in args.budgets.split(","):
        for p in pics:
            styles = one(p, b, args.config)
            runs.append({"picture": os.path.splitext(os.path.basename(p))[0], "budget": b,
                         "styles": styles})
            done, kept = pick(styles, *ours)
            best = max(styles, key=lambda s: styles[s]["final"])
            print(f"\n{runs[-1]['picture']} {b}: kept {kept} {styles[kept]['final']:.3f}, best "
                  f"{best} {styles[best]['final']:.3f}; finished {', '.join(done)}")
            print(f"  {'style':14} {'search s':>8} {'quick s':>7} {'finish s':>8} {'quick':>6} "
                  f"{'bound':>6} {'final':>6} {'q - f':>6}")
            for s in sorted(styles, key=lambda s: -styles[s]["quick"]):
                v = styles[s]
                print(f"  {s:14} {v['search_s']:8.2f} {v['quick_s']:7.2f} {v['finish_s']:8.2f} "
                      f"{v['quick']:6.3f} {v['bound']:6.3f} {v['final']:6.3f} "
                      f"{v['quick'] - v['final']:+6.3f}",
                      flush=True)
    if args.json:
        with open(args.json, "w") as f:
            json.dump(runs, f, indent=1)
    print("\nsettings (finished at most, margin, always): styles finished a run, CPU s of the "
          "search + quick scores + finishes, the kept style's shortfall from the best")
    for f, m, a in (ours, (1, 0.0, ()), (2, 0.03, ("hatch",)), (5, 1.0, ())):
        short, n, cpu = [], 0, 0.0
        for r in runs:
            st = r["styles"]
            done, kept = pick(st, f, m, a)
            n += len(done)
            cpu += sum(v["search_s"] + v["quick_s"] for v in st.values())
            cpu += sum(st[s]["finish_s"] for s in done)
            short.append((max(v["final"] for v in st.values()) - st[kept]["final"],
                          f"{r['picture']} {r['budget']}"))
        worst = max(short)
        print(f"  {f}, {m:.3f}, {'+'.join(a) or '-':6}  {n / len(runs):.2f} finished, "
              f"{cpu / len(runs):.1f} s CPU, worst {worst[0]:.3f} ({worst[1]}), "
              f"{sum(1 for s, _ in short if s > 0.01)} over 0.01")


if __name__ == "__main__":
    main()
