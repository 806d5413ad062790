#!/usr/bin/env bash
# samples/convert-mesh.sh [MESH] [LEVEL] — the pipeline for a mesh of your
# own: any closed genus-0 mesh (OBJ, PLY, STL, OFF, glTF ...) to a regular
# grid with a quality report, refined for display, exported for any viewer
# and drawn into a picture.
#
# Without MESH it takes the Stanford bunny (bunny00.off) from Debian's
# libcgal-demo.  LEVEL (default 6) is the grid level; the display mesh is
# two levels finer.  Results go to $OUT (default build/samples).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
PATH=${NDO_BIN:-$root/bin}:$PATH
out=${OUT:-$root/build/samples}
mesh=${1:-}
level=${2:-6}
mkdir -p "$out"
if [ -z "$mesh" ]; then
	tar -xzf /usr/share/doc/libcgal-dev/data.tar.gz -C "$out" data/meshes/bunny00.off
	mesh=$out/data/meshes/bunny00.off
fi
name=$(basename "${mesh%.*}")

remesh "$mesh" -l "$level" --report -o "$out/$name.tgrid"
subdivide -l 2 "$out/$name.tgrid" -o "$out/$name-fine.obj"
# most mesh files are y-up
render-frame -k 1 --msaa 4 --up 0,1,0 --azimuth 60 --elevation 15 "$out/$name.tgrid" -o "$out/$name.png"
echo "convert-mesh: $out/$name.tgrid (level $level), $out/$name-fine.obj (level $((level + 2))), $out/$name.png"
