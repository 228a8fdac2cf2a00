"""Decode a simulated gpiochip's log of line changes ("<CLOCK_MONOTONIC ns> <line> <0|1>" per
change, lines changed by one ioctl share a time): per-motor steps and step intervals from the
coil patterns (half-step table), illegal transitions, pen pulse widths; with a dry-run trace
(`vplotter draw FILE --dry-run --trace dry.csv`), whether the played coil patterns equal the
planned ones, pattern for pattern. Independent of vplotter (reads only config.toml).

    python -m bench.reference.shim_decode pins.log config.toml [dry.csv]

How the figures in the README's "Measured on the real lgpio library" were made: build the
shim from its source with gcc into /tmp, `vplotter calibrate --at 0 0`, then
`LD_PRELOAD=/tmp/gpiochip_shim.so GPIOSHIM_LOG=pins.log vplotter draw FILE --backend lgpio
--trust-position`, stopped twice for 0.3 s with `kill -STOP`/`kill -CONT`.
"""
import sys, tomllib
import numpy as np
log, cfgp = sys.argv[1], sys.argv[2]
cfg = tomllib.load(open(cfgp, "rb"))
L, R, P = cfg["motors"]["left_pins"], cfg["motors"]["right_pins"], cfg["pen"]["pin"]
rate = cfg["motors"]["max_step_rate"]
HALF = [0b0001, 0b0011, 0b0010, 0b0110, 0b0100, 0b1100, 0b1000, 0b1001]
rows = [l.split() for l in open(log) if l.strip()]
t = np.array([int(r[0]) for r in rows]); pin = np.array([int(r[1]) for r in rows]); v = np.array([int(r[2]) for r in rows])
t0 = t.min()
print(f"changes {len(t)} span {(t.max()-t0)/1e9:.2f} s")
level = {}
def motor(pins, name):
    # group by time: pins of one ioctl share a time
    sel = np.isin(pin, pins)
    tt, pp, vv = t[sel], pin[sel], v[sel]
    word, lev = 0, {p: 0 for p in pins}
    steps, bad, times = 0, 0, []
    i = 0
    phase = None
    while i < len(tt):
        j = i
        while j < len(tt) and tt[j] == tt[i]:
            lev[pp[j]] = vv[j]; j += 1
        w = sum(lev[p] << k for k, p in enumerate(pins))
        if w != word:
            if w == 0: phase = None  # release
            elif w in HALF:
                k = HALF.index(w)
                if phase is not None:
                    d = (k - phase) % 8
                    if d in (1, 7): steps += 1 if d == 1 else -1; times.append(tt[i])
                    else: bad += 1
                phase = k
            else: bad += 1
            word = w
        i = j
    times = np.array(times)
    iv = np.diff(times) / 1e6
    lim = 1000 / rate
    short = iv[iv < lim * 0.98]
    print(f"{name}: net steps {steps}, step events {len(times)}, illegal {bad}, min interval {iv.min() if len(iv) else 0:.3f} ms (limit {lim:.3f}), under limit-2%: {len(short)}")
motor(L, "left"); motor(R, "right")
sel = pin == P
tt, vv = t[sel], v[sel]
w, hi = [], None
for a, b in zip(tt, vv):
    if b == 1 and hi is None: hi = a
    elif b == 0 and hi is not None: w.append((a - hi) / 1e3); hi = None
w = np.array(w)
print(f"pen: pulses {len(w)}, final level {vv[-1] if len(vv) else None}, still high at end: {hi is not None}")
if len(w):
    for target in (cfg['pen']['up_us'], cfg['pen']['down_us']):
        near = w[np.abs(w - target) < 300]
        if len(near): print(f"  ~{target}: n={len(near)} median {np.median(near):.1f} min {near.min():.1f} max {near.max():.1f}")
    far = w[(np.abs(w - cfg['pen']['up_us']) >= 20) & (np.abs(w - cfg['pen']['down_us']) >= 20)]
    print(f"  pulses off by >=20us: {len(far)} {np.round(far[:10],1).tolist()}")
if len(sys.argv) > 3:   # compare per-motor coil pattern sequences with a dry-run trace
    import csv
    def seq_from(events, pins):
        lev = {p: 0 for p in pins}; out = []; cur = None
        events = sorted(events, key=lambda e: e[0])
        i = 0
        while i < len(events):
            j = i
            while j < len(events) and events[j][0] == events[i][0]:
                if events[j][1] in lev: lev[events[j][1]] = events[j][2]
                j += 1
            w = sum(lev[p] << k for k, p in enumerate(pins))
            if w != cur: out.append(w); cur = w
            i = j
        return [w for w in out if w]   # energised patterns in order
    dry = [(float(r[0]), int(r[1]), int(r[2])) for r in csv.reader(l for l in open(sys.argv[3]) if not l.startswith('#')) if r[0] != 't']
    real = list(zip(t.tolist(), pin.tolist(), v.tolist()))
    for name, pins in (("left", L), ("right", R)):
        a, b = seq_from(dry, pins), seq_from(real, pins)
        print(f"{name}: dry-run patterns {len(a)}, played {len(b)}, same sequence: {a == b}")
