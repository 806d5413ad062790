#!/usr/bin/python3
"""summarize_accuracy.py DATA_DIR PART LEVEL... — the condensed tables and
the goals' tallies of tests/bench/accuracy.sh (markdown on stdout).

PART: all (docs/bench/accuracy.md's summary), choices (per input level,
per case E: the choice, predicted / estimated / achieved error, the chosen
run's CPU time and the sweep's cheapest), tallies (how many runs met E,
how many refusals were right — the sweep found nothing meeting E either —
and the cost ratios, the run alone and with choosing counted), misses (the
runs that cost more than 2x the sweep's cheapest), estimates (the
estimates' ratios to the truth and their cost), cost (the chooser's cost
model against measured CPU time per step: cost.csv, no LEVEL)."""
import csv
import os
import statistics
import sys


def rows(path):
    with open(path) as f:
        return list(csv.DictReader(f))


def g(x):
    return f"{float(x):.2g}" if x not in ("", "inf") else ("—" if x == "" else "∞")


def with_choosing(r):
    """The chosen run's CPU time with what choosing it cost (pilots, measured
    levels, critical steps), over the sweep's cheapest run."""
    return (float(r["run_cpu_s"]) + float(r["choose_cpu_s"])) / float(r["cheapest_cpu_s"])


def choices(data, n):
    ch = rows(os.path.join(data, f"choose-{n}.csv"))
    print(f"Input level {n}:\n")
    print("| scene | E | choice | predicted | estimated | achieved | run CPU s | cheapest (sweep) | CPU s | ratio | with choosing |")
    print("|---|---:|---|---:|---:|---:|---:|---|---:|---:|---:|")
    for r in ch:
        if r["reachable"] == "1":
            choice = f"level {r['level']}, {r['method']}, {float(r['step_s']):.3g} s"
            print(f"| {r['scene']} | {g(r['E'])} | {choice} | {g(r['predicted'])} | "
                  f"{g(r['estimated'])} | {g(r['achieved'])} | {float(r['run_cpu_s']):.2g} | "
                  f"{r['cheapest']} | {g(r['cheapest_cpu_s'])} | "
                  f"{g(r['ratio']) if r['cheapest'] != 'none' else '—'} | "
                  f"{g(with_choosing(r)) if r['cheapest'] != 'none' else '—'} |")
        else:
            print(f"| {r['scene']} | {g(r['E'])} | refused: best {g(r['predicted'])}, needs "
                  f"level {r['level']} | | | | | {r['cheapest']} | {g(r['cheapest_cpu_s'])} | | |")
    print()


def tallies(data, n):
    ch = rows(os.path.join(data, f"choose-{n}.csv"))
    ran = [r for r in ch if r["reachable"] == "1"]
    met = [r for r in ran if r["met"] == "1"]
    ref = [r for r in ch if r["reachable"] != "1"]
    right = [r for r in ref if r["cheapest"] == "none"]
    ratios = [float(r["ratio"]) for r in ran if r["ratio"] not in ("", "0")]
    within = [x for x in ratios if x <= 2]
    print(f"- level {n}: {len(met)} of {len(ran)} runs met E against the reference; {len(ref)} "
          f"refused, {len(right)} of them rightly (no configuration in the sweep meets E), "
          f"{len(ref) - len(right)} wrongly (the sweep found one): "
          f"{len(met) + len(right)} of {len(ch)} cases answered correctly.", end="")
    same = [r for r in ran if r["cheapest"] == f"level {r['level']} {r['method']} {r['step_s']} s"]
    if ratios:
        print(f" Chosen run's CPU time over the sweep's cheapest (runs whose E the sweep "
              f"met): median {statistics.median(ratios):.2g}, {len(within)} of {len(ratios)} "
              f"within 2× (largest {max(ratios):.2g}); {len(same)} of them chose the sweep's "
              f"cheapest configuration itself.", end="")
        wc = [with_choosing(r) for r in ran if r["ratio"] not in ("", "0")]
        print(f" With choosing counted (its CPU time added to the run's): median "
              f"{statistics.median(wc):.2g}, {len([x for x in wc if x <= 2])} of {len(wc)} "
              f"within 2× ({min(wc):.2g} to {max(wc):.2g}).")
    else:
        print()


def misses(data, levels):
    print("| input level | scene | E | choice | predicted | achieved | cheapest (sweep) | its error "
          "| its level's predicted space error | ratio | with choosing |")
    print("|---:|---|---:|---|---:|---:|---|---:|---:|---:|---:|")
    for n in levels:
        # The cheapest configuration's true error: from the sweep's points,
        # or, without them (a report rebuilt from the tables), the level
        # table's error of that method at 0.9 x its critical step, the
        # sweep's first step at each level (marked *).
        pts = {}
        sweep = os.path.join(data, f"sweep-{n}.csv")
        if os.path.exists(sweep):
            for p in rows(sweep):
                pts[(p["scene"], p["level"], p["method"], f"{float(p['step_s']):.4g}")] = \
                    g(p["error"])
        first = {(r["scene"], r["level"], m): g(r[f"true_{m.replace('-', '_')}"]) + "*"
                 for r in rows(os.path.join(data, f"levels-{n}.csv"))
                 for m in ("symplectic-euler", "rk4")}
        pred = {(r["scene"], r["level"]): g(r["predicted_space"]) + f" ({r['pilots']})"
                for r in rows(os.path.join(data, f"levels-{n}.csv"))}
        for r in rows(os.path.join(data, f"choose-{n}.csv")):
            if r["reachable"] != "1" or r["ratio"] in ("", "0") or float(r["ratio"]) <= 2:
                continue
            c = r["cheapest"].split()
            err = pts.get((r["scene"], c[1], c[2], c[3])) or first.get((r["scene"], c[1], c[2]))
            print(f"| {n} | {r['scene']} | {g(r['E'])} | level {r['level']}, {r['method']}, "
                  f"{float(r['step_s']):.3g} s | {g(r['predicted'])} | {g(r['achieved'])} | "
                  f"{r['cheapest']} | {err or '?'} | {pred.get((r['scene'], c[1]), '?')} | {g(r['ratio'])} | "
                  f"{g(with_choosing(r))} |")


def estimates(data, n):
    path = os.path.join(data, f"estimates-{n}.csv")
    if not os.path.exists(path):
        return
    es = rows(path)
    parts = []
    for m in ("rk4", "symplectic-euler"):
        e = [r for r in es if r["method"] == m]
        for part in ("space", "time", "total"):
            v = [float(r[f"{part}_ratio"]) for r in e]
            if not v:
                continue
            inside = [x for x in v if 1 / 3 <= x <= 3]
            parts.append(f"{m}, {part}: estimated / true {min(v):.2g} to {max(v):.2g}, "
                         f"{len(inside)} of {len(v)} within 3×")
    cost = [float(r["estimate_cpu_s"]) / float(r["run_cpu_s"]) for r in es
            if float(r["run_cpu_s"]) > 0]
    steps = [round(1 / float(r["step_s"])) for r in es]
    print(f"- level {n} ({len(es)} runs): " + "; ".join(parts) + ".", end="")
    if cost:
        print(f" The estimate's CPU time over the run's: median {statistics.median(cost):.2g} "
              f"({min(cost):.2g} to {max(cost):.2g}; these runs take {min(steps)} to "
              f"{max(steps)} steps per simulated second).")
    else:
        print()


def cost(data):
    """Per method: the code's model against the measurements, and the
    constants a least-squares fit of the relative error gives."""
    import numpy as np
    rs = [r for r in rows(os.path.join(data, "cost.csv")) if r["cpu_per_step_us"] != "inf"]
    print("| method | measured / model | fit: A, µs per step | B, ns per vertex-step | "
          "C, ns per integrated vertex-step | measured / fit |")
    print("|---|---|---:|---:|---:|---|")
    for m in sorted({r["method"] for r in rs}):
        R = [r for r in rs if r["method"] == m]
        t = np.array([float(r["cpu_per_step_us"]) for r in R])
        X = np.array([[1, float(r["vertices"]), float(r["integrated"])] for r in R])
        c, *_ = np.linalg.lstsq(X / t[:, None], np.ones(len(t)), rcond=None)
        q = [float(r["measured_over_model"]) for r in R]
        f = t / (X @ c)
        print(f"| {m} | {min(q):.2f} to {max(q):.2f} (median {statistics.median(q):.2f}) | "
              f"{c[0]:.3g} | {1e3 * c[1]:.3g} | {1e3 * c[2]:.3g} | {f.min():.2f} to {f.max():.2f} |")


def main(data, part, levels):
    if part == "cost":
        cost(data)
        return
    if part == "misses":
        misses(data, levels)
        return
    for n in levels:
        if part in ("all", "choices"):
            choices(data, n)
        if part in ("all", "tallies"):
            tallies(data, n)
        if part in ("all", "estimates"):
            estimates(data, n)
        if part == "all":
            print()


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2], sys.argv[3:])
