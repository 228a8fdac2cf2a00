"""Writes generative.svg: plotter art in the shape vpype writes it (mm page, px user units,
one Inkscape layer per pen): flow-field lines, stipple dots (zero-length subpaths) and
circle packing. Deterministic: `python svg_samples/make_generative.py [N_LINES] [OUT]`."""

import math
import random
import sys

n_lines = int(sys.argv[1]) if len(sys.argv) > 1 else 800
out = sys.argv[2] if len(sys.argv) > 2 else "svg_samples/generative.svg"
rng = random.Random(11)
PX = 96 / 25.4
size_mm = 200.0
size = size_mm * PX


def field(x, y):
    return math.sin(x / 90) * 2.1 + math.cos(y / 70) * 1.7 + math.sin((x + y) / 200)


lines = []
for _ in range(n_lines):
    x, y = rng.uniform(40, size - 40), rng.uniform(40, size - 40)
    pts = [(x, y)]
    for _ in range(rng.randint(4, 30)):
        a = field(x, y)
        x, y = x + 4 * math.cos(a), y + 4 * math.sin(a)
        if not (20 < x < size - 20 and 20 < y < size - 20):
            break
        pts.append((x, y))
    if len(pts) > 1:
        lines.append("M" + " L".join(f"{px:.3f},{py:.3f}" for px, py in pts))
dots = []
for k in range(n_lines // 2):
    r = math.sqrt(k / (n_lines // 2)) * size * 0.3
    a = k * math.pi * (3 - math.sqrt(5))
    dots.append(f"M{size / 2 + r * math.cos(a):.3f},{size / 2 + r * math.sin(a):.3f}z")
circles = []
placed = []
for _ in range(4000):
    cx, cy, r = rng.uniform(60, size - 60), rng.uniform(60, size - 60), rng.uniform(6, 40)
    if all(math.hypot(cx - x, cy - y) > r + q + 3 for x, y, q in placed):
        placed.append((cx, cy, r))
        circles.append(f'<circle cx="{cx:.3f}" cy="{cy:.3f}" r="{r:.3f}"/>')
    if len(placed) >= n_lines // 8:
        break

with open(out, "w") as f:
    f.write('<?xml version="1.0" encoding="utf-8" ?>\n'
            '<svg xmlns="http://www.w3.org/2000/svg" '
            'xmlns:inkscape="http://www.inkscape.org/namespaces/inkscape" '
            f'width="{size_mm:g}mm" height="{size_mm:g}mm" viewBox="0 0 {size:.4f} {size:.4f}">\n')
    f.write('<g inkscape:groupmode="layer" id="layer1" inkscape:label="1 flow" '
            'style="fill:none;stroke:#0000ff;stroke-width:1">\n')
    f.writelines(f'<path d="{d}"/>\n' for d in lines)
    f.write('</g>\n<g inkscape:groupmode="layer" id="layer2" inkscape:label="2 stipple" '
            'style="stroke:#ff0000;stroke-linecap:round;stroke-width:3">\n')
    f.write(f'<path d="{" ".join(dots)}"/>\n')
    f.write('</g>\n<g inkscape:groupmode="layer" id="layer3" inkscape:label="3 circles" '
            'style="fill:none;stroke:#008000">\n')
    f.writelines(c + "\n" for c in circles)
    f.write("</g>\n</svg>\n")
