#!/usr/bin/env bash
# Subdivision speed, ndo beside OpenMesh (tests/bench/bench_subdivide.cpp),
# written to docs/bench/subdivide.md.
set -euo pipefail
cd "$NDO_ROOT"
tmp=$(mktemp -d build/bench/subdivide.XXXXXX)
table=$("$NDO_TESTBIN/bench_subdivide" "$NDO_BIN/subdivide" "$tmp")
rm -rf "$tmp"
{
	echo "# Subdivision speed"
	echo
	echo "Made by \`make bench\` (\`tests/bench/subdivide.sh\`) on $(date -u +%Y-%m-%d),"
	echo "$(nproc) cores of $(sed -n 's/^model name\s*: //p' /proc/cpuinfo | head -1), one thread."
	echo "Medians of repeated runs, all in one run; shape: the wavy sphere."
	echo
	echo "$table"
	echo
	echo "- *ndo kernel*: \`ndo_butterfly_f64\` on positions with buffers reused (pad, three"
	echo "  convolutions, corner rule, sync). *ndo grid*: \`ndo_subdivide\`, which allocates the new grid."
	echo "- *OpenMesh*: \`ModifiedButterflyT\` (Debian libopenmesh-dev) refining an in-memory"
	echo "  \`TriMesh\` of doubles by one level; building the mesh is not timed."
	echo "- *\`subdivide\` process*: the whole command \`subdivide -l 1 IN -o OUT\`, file to file."
} >docs/bench/subdivide.md
cat docs/bench/subdivide.md
