#!/usr/bin/python3
"""plot_simulate.py DATA_DIR FIG_DIR — the figures of docs/simulate-peer.md
from the CSV files tests/bench/simulate-studies.sh makes (bench_study):
stability.png, work-precision.png, levels.png, penalty.png."""
import csv
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

COLORS = {
    "euler": "tab:red",
    "symplectic-euler": "tab:orange",
    "midpoint": "tab:olive",
    "rk4": "tab:blue",
    "rkf45": "tab:purple",
    "backward-euler": "tab:brown",
    "trapezoid": "tab:green",
}


def rows(path):
    with open(path) as f:
        return list(csv.DictReader(f))


def stability(data, out):
    r = rows(os.path.join(data, "stability.csv"))
    fig, ax = plt.subplots(figsize=(7, 5))
    slopes = {"euler": "-1", "midpoint": "-2/3", "symplectic-euler": "-1/2", "rk4": "-1/2",
              "rkf45": "≈ -1/2"}
    for m in COLORS:
        pts = [x for x in r if x["method"] == m]
        if not pts:
            continue
        k = [float(x["k"]) for x in pts]
        ax.plot(k, [float(x["predicted"]) for x in pts], "-", color=COLORS[m],
                label=f"{m} (slope {slopes[m]})")
        ax.plot(k, [float(x["measured"]) for x in pts], "o", color=COLORS[m], mfc="none")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("stiffness k (N/m)")
    ax.set_ylabel("step h at divergence (s)")
    ax.set_title("Divergence step against stiffness (thesis figure 5.2)\n"
                 "lines: predicted from λ_max(M⁻¹K); circles: measured", fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(os.path.join(out, "stability.png"), dpi=110)


def work_precision(data, out):
    r = rows(os.path.join(data, "accuracy.csv"))
    levels = sorted({int(x["level"]) for x in r})
    fig, axes = plt.subplots(1, len(levels), figsize=(5 * len(levels), 4.6), sharey=True)
    if len(levels) == 1:
        axes = [axes]
    for ax, level in zip(axes, levels):
        for m in COLORS:
            pts = sorted((float(x["cpu_s"]), float(x["relative"])) for x in r
                         if x["method"] == m and int(x["level"]) == level)
            if pts:
                ax.plot([p[0] for p in pts], [p[1] for p in pts], "o-", color=COLORS[m],
                        label=m, ms=4)
        ax.set_xscale("log")
        ax.set_yscale("log")
        nodes = 2 * 4 ** level + 2
        ax.set_title(f"level {level} ({nodes} nodes)", fontsize=10)
        ax.set_xlabel("CPU time for 1 s simulated (s)")
        ax.grid(True, which="both", alpha=0.3)
    axes[0].set_ylabel("max position error / max displacement")
    axes[0].legend(fontsize=8)
    fig.suptitle("Work-precision on the thesis scene (k = 1 N/m, b = 0.1, 2.4 N at 1 Hz)",
                 fontsize=11)
    fig.tight_layout()
    fig.savefig(os.path.join(out, "work-precision.png"), dpi=110)


def levels(data, out):
    r = rows(os.path.join(data, "levels.csv"))
    fine = r[0]
    coarse = r[1:]
    fig, ax = plt.subplots(figsize=(6.5, 4.6))
    lv = [int(x["level"]) for x in coarse]
    ax.semilogy(lv, [float(x["relative_displacement_max"]) for x in coarse], "o-",
                label="max displacement error / max displacement")
    ax.semilogy(lv, [float(x["displacement_rms_m"]) / float(x["displacement_max_m"]) *
                     float(x["relative_displacement_max"]) for x in coarse], "s--",
                label="RMS displacement error / max displacement")
    for x in coarse:
        ax.annotate(f"{float(x['cpu_s']) * 1e3:.3g} ms", (int(x["level"]),
                    float(x["relative_displacement_max"])), textcoords="offset points",
                    xytext=(5, 5), fontsize=8)
    ax.set_xlabel(f"simulated at level L, subdivided to level {fine['level']}")
    ax.set_xticks(lv)
    ax.set_title(f"Simulate coarse, subdivide for display, against simulating at level "
                 f"{fine['level']}\n(RK4, 1 s of the thesis scene; CPU time per run; level "
                 f"{fine['level']} took {float(fine['cpu_s']):.3g} s)", fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(os.path.join(out, "levels.png"), dpi=110)


def penalty(data, out):
    r = rows(os.path.join(data, "penalty.csv"))
    a = [float(x["alpha"]) for x in r]
    h = [float(x["h_crit_rk4"]) for x in r]
    fig, ax = plt.subplots(figsize=(6, 4.3))
    ax.loglog(a, h, "o-", label="RK4 critical step")
    ref = h[-1] * (a[-1] / a[-3]) ** 0.5
    ax.loglog([a[-3], a[-1]], [ref, h[-1]], "k--", label="slope -1/2")
    ax.set_xlabel("penalty α (N/m)")
    ax.set_ylabel("critical step (s)")
    ax.set_title("Payne–Irons pins: the stable step shrinks as 1/√α", fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(os.path.join(out, "penalty.png"), dpi=110)


def main():
    data, out = sys.argv[1], sys.argv[2]
    os.makedirs(out, exist_ok=True)
    for fn in (stability, work_precision, levels, penalty):
        try:
            fn(data, out)
        except FileNotFoundError as e:
            print(f"plot_simulate.py: skipping {fn.__name__}: {e}", file=sys.stderr)


if __name__ == "__main__":
    main()
