#!/usr/bin/env bash
# partition — the partition study of issue 6: imbalance and cut length of
# the thesis' Table 4.1, the improved quad tree and METIS for 2..8 peers
# over random points of interest; a picture of a few partitions.
set -euo pipefail
cd "$(dirname "$0")/../.."
out=docs/bench/partition.md
dump=build/bench/partition
mkdir -p "$dump" docs/bench
cmd="build/tests/bench_partition -l 6 -r 200 -s 1 -d $dump"
table=$($cmd)
cmd7="build/tests/bench_partition -l 7 -r 50 -s 2"
table7=$($cmd7)
/usr/bin/python3 tests/bench/partition_plot.py "$dump" docs/bench/partition.png
{
	echo "# Partition study"
	echo
	echo "Area imbalance (largest region / mean), cut length (cell edges between"
	echo "regions, seams included, in lattice units), whether each peer's point of"
	echo "interest lies in its own region, and quad-tree leaves, for the thesis'"
	echo "Table 4.1 (literal), the improved quad tree (\`--partition quadtree\`, the"
	echo "default) and METIS 5.1 k-way (\`--partition metis\`, 1.05 allowed, seed 1)"
	echo "on the same cell graph; random POIs (uniform over faces)."
	echo "\"cut / METIS\" is the ratio per trial (same POIs)."
	echo
	echo "Level 6 (128 × 64 cells), 200 trials per peer count: \`$cmd\`"
	echo
	echo "$table"
	echo
	echo "Level 7 (256 × 128 cells), 50 trials: \`$cmd7\`"
	echo
	echo "$table7"
	echo
	echo "![partitions](partition.png)"
	echo
	echo "Made by \`tests/bench/partition.sh\` on $(date -u +%Y-%m-%d), $(nproc) cores,"
	echo "$(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //')."
} >"$out"
echo "$table"
echo "$table7"
echo "wrote $out"
