#!/usr/bin/python3
"""summarize_accuracy.py DATA_DIR LEVEL... — the condensed tables and the
goals' tallies of tests/bench/accuracy.sh (markdown on stdout): per
case E, the choice, predicted / estimated / achieved error, the chosen
run's CPU time and the sweep's cheapest; then how many runs met E, how
many refusals were right (the sweep found nothing meeting E either), and
the cost ratios; and the estimates' ratios to the truth."""
import csv
import os
import statistics
import sys


def rows(path):
    with open(path) as f:
        return list(csv.DictReader(f))


def g(x):
    return f"{float(x):.2g}" if x not in ("", "inf") else ("—" if x == "" else "∞")


def main(data, levels):
    for n in levels:
        ch = rows(os.path.join(data, f"choose-{n}.csv"))
        print(f"Input level {n}:\n")
        print("| scene | E | choice | predicted | estimated | achieved | run CPU s | cheapest (sweep) | CPU s |")
        print("|---|---:|---|---:|---:|---:|---:|---|---:|")
        for r in ch:
            if r["reachable"] == "1":
                choice = f"level {r['level']}, {r['method']}, {float(r['step_s']):.3g} s"
                print(f"| {r['scene']} | {g(r['E'])} | {choice} | {g(r['predicted'])} | "
                      f"{g(r['estimated'])} | {g(r['achieved'])} | {float(r['run_cpu_s']):.2g} | "
                      f"{r['cheapest']} | {g(r['cheapest_cpu_s'])} |")
            else:
                print(f"| {r['scene']} | {g(r['E'])} | refused: best {g(r['predicted'])}, needs "
                      f"level {r['level']} | | | | | {r['cheapest']} | {g(r['cheapest_cpu_s'])} |")
        ran = [r for r in ch if r["reachable"] == "1"]
        met = [r for r in ran if r["met"] == "1"]
        ref = [r for r in ch if r["reachable"] != "1"]
        right = [r for r in ref if r["cheapest"] == "none"]
        ratios = [float(r["ratio"]) for r in ran]
        within = [x for x in ratios if x <= 2]
        print()
        print(f"- {len(met)} of {len(ran)} runs met E against the reference; {len(ref)} refused, "
              f"{len(right)} of them rightly (no configuration in the sweep meets E), "
              f"{len(ref) - len(right)} wrongly (the sweep found one): "
              f"{len(met) + len(right)} of {len(ch)} cases answered correctly.")
        if ratios:
            print(f"- chosen run's CPU time over the sweep's cheapest: median "
                  f"{statistics.median(ratios):.2g}, {len(within)} of {len(ratios)} within 2× "
                  f"(largest {max(ratios):.2g}).")
        es = rows(os.path.join(data, f"estimates-{n}.csv"))
        for m in ("rk4", "symplectic-euler"):
            e = [r for r in es if r["method"] == m]
            for part in ("space", "time", "total"):
                v = [float(r[f"{part}_ratio"]) for r in e]
                inside = [x for x in v if 1 / 3 <= x <= 3]
                print(f"- estimates, {m}, {part}: estimated / true {min(v):.2g} to {max(v):.2g}, "
                      f"{len(inside)} of {len(v)} within 3×.")
        print()


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2:])
