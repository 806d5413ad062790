#!/usr/bin/python3
"""plot_accuracy.py DATA_DIR LEVEL OUT.png — the work-precision diagram of each
benchmark scene (tests/bench/accuracy.sh: the sweep's points, error against
CPU time) with the configurations --accuracy chose for E = 0.1, 0.01,
0.001 on it (stars; the dotted lines are the targets)."""
import csv
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

COLORS = {"symplectic-euler": "tab:orange", "rk4": "tab:blue"}
MARKERS = {2: "v", 3: "s", 4: "D", 5: "o", 6: "^", 7: "P"}


def rows(path):
    with open(path) as f:
        return list(csv.DictReader(f))


def main(data, level, out):
    sweep = rows(os.path.join(data, f"sweep-{level}.csv"))
    chosen = rows(os.path.join(data, f"choose-{level}.csv"))
    scenes = list(dict.fromkeys(r["scene"] for r in sweep))
    fig, axes = plt.subplots(2, 3, figsize=(13, 8), squeeze=False)
    for ax, sc in zip(axes.flat, scenes):
        for r in (x for x in sweep if x["scene"] == sc):
            ax.loglog(float(r["cpu_s"]), float(r["error"]), MARKERS.get(int(r["level"]), "o"),
                      color=COLORS.get(r["method"], "gray"), alpha=0.45, ms=5)
        for r in (x for x in chosen if x["scene"] == sc):
            E = float(r["E"])
            ax.axhline(E, color="gray", ls=":", lw=0.8)
            if r["reachable"] == "1":
                ax.loglog(float(r["run_cpu_s"]), float(r["achieved"]), "*", ms=14,
                          color=COLORS.get(r["method"], "k"), markeredgecolor="k")
                ax.annotate(f"E={E:g}: L{r['level']}", (float(r["run_cpu_s"]), float(r["achieved"])),
                            textcoords="offset points", xytext=(6, 4), fontsize=8)
        ax.set_title(sc)
        ax.set_xlabel("CPU s per run (median of 3 trials of ≥ 20 ms)")
        ax.set_ylabel("error / largest displacement")
        ax.grid(True, which="both", alpha=0.3)
    for m, c in COLORS.items():
        axes.flat[0].plot([], [], "o", color=c, label=m)
    for lv, mk in MARKERS.items():
        axes.flat[0].plot([], [], mk, color="gray", label=f"level {lv}")
    axes.flat[0].plot([], [], "*", color="k", ms=12, label="--accuracy's choice")
    axes.flat[0].legend(fontsize=7)
    fig.suptitle(f"work-precision per scene, input level {level}: the sweep and --accuracy's choices")
    fig.tight_layout()
    fig.savefig(out, dpi=90)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2], sys.argv[3])
