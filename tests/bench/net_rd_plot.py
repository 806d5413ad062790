#!/usr/bin/python3
"""net_rd_plot.py ROWS.csv OUT.svg — bits per vertex per update against the
error at the simulated level (max and RMS), one line per level, encoding and
send level, from net-bench's CSV rows (tests/bench/net-rd.sh); prints the
rows as a Markdown table."""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
matplotlib.rcParams["svg.fonttype"] = "none"  # text as text: a small file
import matplotlib.pyplot as plt

rows = list(csv.DictReader(open(sys.argv[1])))
lines = {}
for r in rows:
    enc = r["encoding"].split(":")[0]
    key = (int(r["level"]), enc, int(r["send_level"]))
    lines.setdefault(key, []).append(r)

fig, axes = plt.subplots(1, 2, figsize=(13, 4.8), sharey=True)
colors = {0: "tab:blue", 1: "tab:orange", 2: "tab:green"}
markers = {"float32": "s", "fixed": "^", "predict": "o", "hier": "D"}
for ax, col, name in ((axes[0], "level_max_error_rel", "max"), (axes[1], "level_rms_error_rel", "RMS")):
    for (level, enc, send), pts in sorted(lines.items()):
        pts = sorted(pts, key=lambda r: float(r[col]))
        xs = [float(r[col]) for r in pts]
        ys = [float(r["bits_per_vertex_update"]) for r in pts]
        ax.plot(xs, ys, marker=markers.get(enc, "x"), color=colors.get(level - send, "gray"),
                linestyle="-" if level == 6 else "--", markersize=4,
                label=f"level {level} at {send}, {enc}")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel(f"{name} error at the simulated level / diagonal")
    ax.grid(True, which="major", alpha=0.3)
axes[0].set_ylabel("bits per vertex per update (wire)")
axes[1].legend(fontsize=6, loc="upper left", bbox_to_anchor=(1.02, 1))
fig.suptitle("thesis scene, 1 peer streaming to an observer: solid level 6, dashed level 7; "
             "colour: send level 0/1/2 below", fontsize=9)
fig.tight_layout()
fig.savefig(sys.argv[2], metadata={"Date": None})

print("| level | encoding | send level | bits/vertex/update | bits/node/update (W x H) "
      "| max error | RMS error | disp max | disp RMS |")
print("|---:|---|---:|---:|---:|---:|---:|---:|---:|")
for r in rows:
    print(f"| {r['level']} | {r['encoding']} | {r['send_level']} | {float(r['bits_per_vertex_update']):.3g} "
          f"| {float(r['bits_per_node_update']):.3g} | {float(r['level_max_error_rel']):.4g} "
          f"| {float(r['level_rms_error_rel']):.3g} | {float(r['disp_max_error_rel']):.3g} "
          f"| {float(r['disp_rms_error_rel']):.3g} |")
