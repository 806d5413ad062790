#!/usr/bin/env bash
# hier-speed — hier's encode and decode of a whole level-7 state, one
# thread (issue 20's ≤ 1 ms), paired: this tree's build/tests/bench_codec
# against the same program linked with lib/net/codec_hier.c as it was at
# git revision REV (the rest of the library this tree's), alternating,
# RUNS runs each of the thesis' scene for 5 s.  Each
# run's figures are bench_codec's medians over its steps (CPU time of the
# thread); the table gives the median and range over the runs, and checks
# both builds write the same payloads (CRC-32).  Prints the table and the
# load average; the machine is shared, so only the ratio of the two
# columns means anything under load.
#   tests/bench/hier-speed.sh REV [RUNS [LEVEL]]
set -euo pipefail
cd "$(dirname "$0")/../.."
rev=${1:?usage: tests/bench/hier-speed.sh REV [RUNS [LEVEL]]}
runs=${2:-5}
level=${3:-7}
new=build/tests/bench_codec
make -s "$new" >/dev/null
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
# the reference: codec_hier.c at REV, compiled as the Makefile compiles it
git show "$rev:lib/net/codec_hier.c" >"$work/codec_hier.c" ||
	{ echo "hier-speed: no lib/net/codec_hier.c at $rev" >&2; exit 2; }
gcc -D_GNU_SOURCE -std=c11 -O2 -Ilib/net -Ilib/sim -Ilib/grid -Ibuild/gen \
	-c -o "$work/codec_hier.c.o" "$work/codec_hier.c"
cp lib/libndo.a "$work/libndo.a"
ar r "$work/libndo.a" "$work/codec_hier.c.o"
ref=build/bench/hier-speed-ref-bench_codec
mkdir -p build/bench
gcc -o "$ref" build/obj/tests/bench/bench_codec.c.o "$work/libndo.a" -lassimp -lz -lzstd -lm \
	-llcm -lmetis -lsodium -lcholmod -llapack -lblas
for ((k = 0; k < runs; k++)); do
	for who in ref new; do
		b=$ref
		[ $who = new ] && b=$new
		"$b" -l "$level" -e hier:1e-4 -p 1 -t 5 >>"$work/$who.txt"
	done
done
/usr/bin/python3 - "$work" "$rev" "$level" <<'PY'
import re, statistics, sys
work, rev, level = sys.argv[1:]
rows = {}
for who in ("ref", "new"):
    enc, dec, crc, bits = [], [], set(), set()
    for line in open(f"{work}/{who}.txt"):
        m = re.search(r"CPU time ([0-9.]+) \+ ([0-9.]+) ms", line)
        enc.append(float(m.group(1))), dec.append(float(m.group(2)))
        crc.add(re.search(r"CRC-32 ([0-9a-f]+)", line).group(1))
        bits.add(re.search(r"([0-9.]+) bits/node/update", line).group(1))
    rows[who] = (enc, dec, crc, bits)
print(f"| build | runs | encode ms (CPU) | decode ms (CPU) | enc + dec | bits/node/update | payload CRC-32 |")
print("|---|---:|---:|---:|---:|---:|---|")
med = {}
for who, path in ((f"ref", f"codec_hier.c at {rev}"), ("new", "this tree")):
    enc, dec, crc, bits = rows[who]
    e, d = statistics.median(enc), statistics.median(dec)
    med[who] = e + d
    print(f"| {path} | {len(enc)} | {e:.3f} ({min(enc):.3f}-{max(enc):.3f}) | {d:.3f} "
          f"({min(dec):.3f}-{max(dec):.3f}) | {e + d:.3f} | {'/'.join(sorted(bits))} | {'/'.join(sorted(crc))} |")
print(f"\nnew / ref (enc + dec): {med['new'] / med['ref']:.3f}; level {level}, hier:1e-4, 1 peer, "
      f"same payloads: {'yes' if rows['ref'][2] == rows['new'][2] else 'NO'}")
PY
echo "load average: $(cat /proc/loadavg)"
