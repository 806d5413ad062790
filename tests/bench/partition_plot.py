#!/usr/bin/python3
"""partition_plot.py DUMPDIR OUT.png — draw partitions of the unfolded grid
(2N x N cells; the four tetrahedron faces in a strip) for 3 and 5 peers:
Table 4.1, the improved quad tree and METIS side by side; black dots are
the points of interest."""
import sys
import numpy as np
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt

d, out = sys.argv[1], sys.argv[2]
methods = ["table41", "quadtree", "metis"]
fig, axes = plt.subplots(2, 3, figsize=(13, 4.6))
for r, k in enumerate([3, 5]):
    pois = np.loadtxt(f"{d}/pois-k{k}.txt", dtype=int)
    pj, pi = np.nonzero(pois >= 0)
    for c, m in enumerate(methods):
        cells = np.loadtxt(f"{d}/{m}-k{k}.txt", dtype=int)
        ax = axes[r][c]
        ax.imshow(cells, origin="lower", cmap="tab10", vmin=0, vmax=9,
                  interpolation="nearest")
        n = cells.shape[0]
        for x in (n, ):  # the fold between the two squares (depth-1 nodes)
            ax.axvline(x - 0.5, color="white", lw=0.6)
        ax.plot([-0.5, n - 0.5], [-0.5, n - 0.5], color="white", lw=0.4)
        ax.plot([n - 0.5, 2 * n - 0.5], [-0.5, n - 0.5], color="white", lw=0.4)
        ax.scatter(pi, pj, c="black", s=14)
        ax.set_title(f"{m}, {k} peers", fontsize=9)
        ax.set_xticks([]), ax.set_yticks([])
fig.suptitle("Partitions of the level-6 grid (unfolded tetrahedron; seams wrap left-right, "
             "bottom and top rows fold at their middles)", fontsize=9)
fig.tight_layout()
fig.savefig(out, dpi=110)
