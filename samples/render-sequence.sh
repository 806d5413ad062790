#!/usr/bin/env bash
# samples/render-sequence.sh [SCENE] — simulate a scene, keep a frame every
# few steps, draw the frames into a numbered PNG sequence coloured by
# displacement and, where ffmpeg is installed, into a video.
#
# SCENE defaults to samples/thesis-fig5.3.scene (the wavy surface pushed by
# sinusoidal forces).  LEVEL (default 5), TIME (simulated seconds, default
# 2) and EVERY (steps per frame, default 5) can be set in the environment.
# Results go to $OUT/sequence (OUT defaults to build/samples).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
PATH=${NDO_BIN:-$root/bin}:$PATH
scene=${1:-$root/samples/thesis-fig5.3.scene}
out=${OUT:-$root/build/samples}/sequence
rm -rf "$out/frames" "$out/png"
mkdir -p "$out/frames" "$out/png"

remesh --shape wavy -l "${LEVEL:-5}" |
	simulate-peer -q -s "$scene" --time "${TIME:-2}" --frames "$out/frames/f%04d.tgrid" \
		--frame-every "${EVERY:-5}" -o "$out/end.tgrid"
render-frame -k 1 --color-by displacement -o "$out/png/f%04d.png" "$out"/frames/*.tgrid
n=$(ls "$out/png" | wc -l)
echo "render-sequence: $n frames in $out/png/"
if command -v ffmpeg >/dev/null; then
	ffmpeg -y -loglevel error -framerate 25 -i "$out/png/f%04d.png" -pix_fmt yuv420p "$out/run.mp4"
	echo "render-sequence: $out/run.mp4"
else
	echo "render-sequence: no ffmpeg, so no video (apt-get install ffmpeg)"
fi
