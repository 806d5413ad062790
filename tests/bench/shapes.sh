#!/usr/bin/env bash
# The two sphere maps compared (tests/bench/bench_shapes.c) → docs/bench/shapes.md.
set -euo pipefail
cd "$NDO_ROOT"
table=$("$NDO_TESTBIN/bench_shapes")
{
	echo "# Sphere maps: triangle quality and stable step"
	echo
	echo "Made by \`make bench\` (\`tests/bench/shapes.sh\`) on $(date -u +%Y-%m-%d). The unit"
	echo "sphere grid from each tetrahedron→sphere map; λ_max of M⁻¹L by power iteration."
	echo
	echo "$table"
} >docs/bench/shapes.md
cat docs/bench/shapes.md
