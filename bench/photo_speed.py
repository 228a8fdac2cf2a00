"""`vplotter convert` on photos: wall time, peak memory and plot time against the budget; and
the files it must refuse (one line, quickly).

Pictures (made here, in a temporary folder): a 12-megapixel JPEG (4000 x 3000, photo-like:
gradients, lit discs, soft noise) stored with EXIF orientation 6 (shown upright as 3000 x 4000),
a 1200 x 900 PNG and a 640 x 480 JPEG of the same scene. For each picture, style and budget
(1 h, 3 h) at --width 300 on ./config.toml: the wall time of `vplotter convert` (a
subprocess) and its CPU time (user + sys, RUSAGE_CHILDREN: steadier than the wall time on a
shared machine), its peak resident size (/usr/bin/time -f %M when there is one, else
RUSAGE_CHILDREN of a fresh child; `--style auto`, two processes: the larger one's), and the
plot time `vplotter estimate OUT.ngc` gives for the result against the budget.

Bad files: a decompression bomb (a PNG whose IHDR claims 30000 x 30000, built with struct and
zlib: 900 MB of pixels if decoded), an empty file, a text file named .png and a JPEG cut in
half: exit status, the one line it printed, the time.

Run (from the repository root, in vplotter's venv): python -m bench.photo_speed
    [--budgets 1h,3h] [--styles hatch,spiral,squiggle,stipple,flow,tsp,auto] [--first N]
    [--runs N] [--idle]
    (tsp: stipple --tsp; auto: --style auto, every style tried; --runs: each convert N times,
    one row each; --idle: each convert started once every core has been at least 90 % idle
    for 3 s, on a shared machine; another version: PYTHONPATH=OLD/src python -m ...)
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import struct
import subprocess
import tempfile
import time
import zlib

from bench import ROOT
STYLES = ("hatch", "spiral", "squiggle", "stipple", "flow")


def scene(w: int, h: int):
    from bench.image_styles import scene as make     # the photo-like scene of bench/image_styles.py

    return make(w, h)


def pictures(tmp: str) -> list[str]:
    from PIL import Image

    big = scene(4000, 3000).transpose(Image.Transpose.ROTATE_90)   # stored on its side
    exif = Image.Exif()
    exif[0x0112] = 6
    p12 = os.path.join(tmp, "phone-12mp-exif6.jpg")
    big.save(p12, quality=90, exif=exif)
    mid = os.path.join(tmp, "scene-1200x900.png")
    scene(1200, 900).save(mid)
    small = os.path.join(tmp, "scene-640x480.jpg")
    scene(640, 480).save(small, quality=90)
    return [p12, mid, small]


def bad_files(tmp: str, jpeg: str) -> list[str]:
    def chunk(kind: bytes, data: bytes) -> bytes:
        return (struct.pack(">I", len(data)) + kind + data
                + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF))

    bomb = os.path.join(tmp, "bomb-30000x30000.png")
    rows = zlib.compress(b"\x00" * 30001, 9)      # one row; the header claims 30000
    with open(bomb, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", 30000, 30000, 8, 0,
                                                                   0, 0, 0))
                + chunk(b"IDAT", rows) + chunk(b"IEND", b""))
    empty = os.path.join(tmp, "empty.jpg")
    open(empty, "wb").close()
    text = os.path.join(tmp, "notes.png")
    with open(text, "w") as f:
        f.write("this is not a picture\n" * 20)
    cut = os.path.join(tmp, "truncated.jpg")
    with open(jpeg, "rb") as f:
        data = f.read()
    with open(cut, "wb") as f:
        f.write(data[: len(data) // 2])
    return [bomb, empty, text, cut]


def run(args: list[str]) -> tuple[int, str, float, float, float]:
    """(exit status, stderr, wall s, peak RSS MB, CPU s: user + sys) of a vplotter command."""
    import resource

    timer = shutil.which("time") or ("/usr/bin/time" if os.path.exists("/usr/bin/time") else None)
    rss_file = tempfile.mktemp(suffix=".rss")
    cmd = ["vplotter", *args]
    if timer:
        cmd = [timer, "-f", "%M", "-o", rss_file] + cmd
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    r = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    if timer:
        with open(rss_file) as f:
            rss = int(f.read().strip().splitlines()[-1]) / 1024
        os.unlink(rss_file)
    else:
        rss = after.ru_maxrss / 1024                   # a high-water mark
    return r.returncode, r.stderr, wall, rss, cpu


def wait_idle(share: float = 0.9, seconds: float = 3.0) -> float:
    """Wait until the machine's CPUs have been at least `share` idle over `seconds` (Linux's
    /proc/stat; elsewhere at once); the idle share seen."""
    def counts() -> tuple[int, int]:
        with open("/proc/stat") as f:
            v = [int(x) for x in f.readline().split()[1:]]
        return v[3] + v[4], sum(v)

    if not os.path.exists("/proc/stat"):
        return float("nan")
    while True:
        a = counts()
        time.sleep(seconds)
        b = counts()
        idle = (b[0] - a[0]) / max(1, b[1] - a[1])
        if idle >= share:
            return idle


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--budgets", default="1h,3h")
    ap.add_argument("--styles", default=",".join(STYLES))
    ap.add_argument("--config", default=os.path.join(ROOT, "config.toml"))
    ap.add_argument("--first", type=int, default=3, help="only the first N pictures (12 MP first)")
    ap.add_argument("--runs", type=int, default=1, help="each convert this many times")
    ap.add_argument("--idle", action="store_true", help="start each convert on an idle machine")
    args = ap.parse_args()
    cfg = ["--config", args.config]
    with tempfile.TemporaryDirectory() as tmp:
        pics = pictures(tmp)
        print(f"{'picture':22} {'style':9} {'budget':6} {'wall s':>7} {'CPU s':>6} {'RSS MB':>7} "
              f"{'plot time':>9} {'/ budget':>8}  chosen")
        for pic in pics[:args.first]:
            for b in args.budgets.split(","):
                budget = {"h": 3600, "m": 60}[b[-1]] * float(b[:-1])
                for s in [s for s in args.styles.split(",") for _ in range(args.runs)]:
                    out = os.path.join(tmp, "out.ngc")
                    how = ["--style", "stipple", "--tsp"] if s == "tsp" else ["--style", s]
                    if args.idle:
                        wait_idle()
                    code, err, wall, rss, cpu = run([*cfg, "convert", pic, "-o", out, *how,
                                                     "--width", "300", "--max-time", b])
                    if code:
                        print(f"{os.path.basename(pic):22} {s:9} {b:6} failed: {err.strip()}")
                        continue
                    r = subprocess.run(["vplotter", *cfg, "estimate", out], capture_output=True,
                                       text=True)
                    m = re.search(r"plot time [0-9:]+ \(([0-9.]+) s\)", r.stdout)
                    plot = float(m.group(1)) if m else float("nan")
                    chosen = re.search(r"spacing [0-9.]+ mm", err)
                    kept = re.search(r"--style auto chose (\S+(?: --tsp)?) ", err)
                    chosen = kept or chosen
                    print(f"{os.path.basename(pic):22} {s:9} {b:6} {wall:7.1f} {cpu:6.1f} "
                          f"{rss:7.0f} {time.strftime('%H:%M:%S', time.gmtime(plot)):>9} "
                          f"{plot / budget:8.3f}  {chosen.group(0) if chosen else ''}", flush=True)
        print(f"\n{'bad file':22} {'exit':>4} {'wall s':>6}  the line")
        for bad in bad_files(tmp, pics[2]):
            code, err, wall, _, _ = run([*cfg, "convert", bad, "-o", os.path.join(tmp, "bad.ngc"),
                                      "--style", "hatch", "--width", "300"])
            lines = [x for x in err.strip().splitlines() if not x.startswith("note:")]
            print(f"{os.path.basename(bad):22} {code:4d} {wall:6.2f}  "
                  f"{' | '.join(lines) if lines else '(nothing)'} ({len(lines)} line"
                  f"{'s' if len(lines) != 1 else ''})", flush=True)


if __name__ == "__main__":
    main()
