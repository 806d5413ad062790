#!/usr/bin/python3
"""peers_plot.py OUT.svg < TABLE — speedup of exact lock-step peers over one
process against the level, one line per row label of the markdown table of
tests/bench/peers.sh section 4 (a colour per peer count; dashed: the
quad-tree's regions, dotted: frames every 10 steps, thin: no frames between).  Plain SVG: no plotting
library needed."""
import sys

rows = {}
for line in sys.stdin:
    f = [c.strip() for c in line.strip().strip("|").split("|")]
    if len(f) < 5 or not f[0].isdigit() or not f[1].split(" ")[0].isdigit() or "process" in f[1]:
        continue
    try:
        rows.setdefault(f[1], []).append((int(f[0]), float(f[4])))
    except ValueError:
        pass
W, H, L, B = 560, 340, 60, 40
levels = sorted({lv for pts in rows.values() for lv, _ in pts}) or [5, 9]
ymax = max([2.0] + [s for pts in rows.values() for _, s in pts])
x = lambda lv: L + (lv - levels[0]) / max(1, levels[-1] - levels[0]) * (W - L - 20)
y = lambda s: H - B - s / ymax * (H - B - 20)
out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{W}" height="{H}" '
       'font-family="sans-serif" font-size="11">',
       f'<rect width="{W}" height="{H}" fill="white"/>',
       f'<line x1="{L}" y1="{H-B}" x2="{W-20}" y2="{H-B}" stroke="black"/>',
       f'<line x1="{L}" y1="{H-B}" x2="{L}" y2="20" stroke="black"/>',
       f'<line x1="{L}" y1="{y(1):.1f}" x2="{W-20}" y2="{y(1):.1f}" stroke="gray" '
       'stroke-dasharray="4 3"/>',
       f'<text x="{W/2}" y="{H-8}" text-anchor="middle">level</text>',
       f'<text x="14" y="{H/2}" transform="rotate(-90 14 {H/2})" text-anchor="middle">'
       'steps/s over one process</text>']
for lv in levels:
    out.append(f'<text x="{x(lv):.1f}" y="{H-B+14}" text-anchor="middle">{lv}</text>')
k = 0.0
while k <= ymax + 1e-9:
    out.append(f'<text x="{L-6}" y="{y(k)+4:.1f}" text-anchor="end">{k:g}</text>')
    k += 0.5
colors = {1: "#7f7f7f", 2: "#1f77b4", 4: "#ff7f0e", 8: "#d62728"}
order = lambda label: (int(label.split(" ")[0]), label)
for i, (label, pts) in enumerate(sorted(rows.items(), key=lambda r: order(r[0]))):
    pts.sort()
    n = int(label.split(" ")[0])
    c = colors.get(n, "black")
    dash = (' stroke-dasharray="6 3"' if "quad-tree" in label else
            ' stroke-dasharray="2 2"' if "every 10" in label else "")
    width = 1 if "no frames" in label else 2
    path = " ".join(f"{x(lv):.1f},{y(s):.1f}" for lv, s in pts)
    out.append(f'<polyline points="{path}" fill="none" stroke="{c}" stroke-width="{width}"{dash}/>')
    for lv, s in pts:
        out.append(f'<circle cx="{x(lv):.1f}" cy="{y(s):.1f}" r="3" fill="{c}"/>')
    name = f'{n} peer{"s" if n > 1 else ""}{label[len(str(n)):]}'
    out.append(f'<text x="{L+10}" y="{30+14*i}" fill="{c}">{name}</text>')
out.append("</svg>")
open(sys.argv[1], "w").write("\n".join(out) + "\n")
