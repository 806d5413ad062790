#!/usr/bin/env bash
# simulate-peer's failures: one line on stderr, the documented exit code,
# nothing written.
. "$(dirname "$0")/lib.sh"

remesh --shape sphere -l 3 -o s3.tgrid
remesh --shape sphere -l 4 -o s4.tgrid
head -c 100 s3.tgrid >trunc.tgrid
printf 'stiffness 1\nintegrator leapfrog\n' >bad.scene

expect_error "stiffness out of range" 2 '^simulate-peer: --stiffness: 0 is outside \(0, 1e\+12\]$' \
	simulate-peer -k 0 s3.tgrid -o o.tgrid
expect_error "unknown integrator" 2 "--integrator: 'verlet' is not euler" \
	simulate-peer -i verlet s3.tgrid -o o.tgrid
expect_error "steps not an integer" 2 "--steps: '1.5' is not an integer" \
	simulate-peer -n 1.5 s3.tgrid -o o.tgrid
expect_error "no threads" 2 "--threads 0: give 1\.\.[0-9]+ \(the processors" \
	simulate-peer --threads 0 s3.tgrid -o o.tgrid
expect_error "more threads than processors" 2 "--threads 100000: give 1\.\.[0-9]+" \
	simulate-peer --threads 100000 s3.tgrid -o o.tgrid
remesh --shape sphere -l 6 -o s6.tgrid
expect_error "memory limit, explicit" 1 "level 6 with rk4 needs about 3.[0-9]+ MB; the limit is 2 MB" \
	simulate-peer --max-memory 2M s6.tgrid -o o.tgrid
expect_error "memory limit, CHOLMOD's factor" 1 "step 1: level 6 with backward-euler needs about .* nonzeros in CHOLMOD's factor\); the limit is 3 MB" \
	simulate-peer -q -i backward-euler --solver cholmod --dt 0.01 --max-memory 3M s6.tgrid -o o.tgrid
# The multigrid's hierarchy is sized before anything is allocated (auto
# takes multigrid at level 6): 3.8 MB of arrays and about 5 MB more.
expect_error "memory limit, the multigrid hierarchy" 1 "level 6 with backward-euler needs about [5-9].[0-9]+ MB; the limit is 5 MB" \
	simulate-peer -q -i backward-euler --dt 0.01 --max-memory 5M s6.tgrid -o o.tgrid
expect_error "--no-estimate with --accuracy" 2 "--no-estimate: not with --accuracy" \
	simulate-peer --no-estimate --accuracy 0.1 -t 1 s3.tgrid -o o.tgrid
expect_error "--no-estimate on a peer" 2 "--no-estimate: a single process only" \
	simulate-peer --owner --no-estimate s3.tgrid -o o.tgrid
expect_error "unknown solver" 2 "--solver: 'lu' is not auto, multigrid or cholmod" \
	simulate-peer -i trapezoid --solver lu s3.tgrid -o o.tgrid
expect_error "memory limit too small to mean anything" 2 "--max-memory 5: give bytes from 1k" \
	simulate-peer --max-memory 5 s4.tgrid -o o.tgrid
expect_error "dt negative" 2 '--dt: -1 is outside' simulate-peer --dt -1 s3.tgrid -o o.tgrid
expect_error "bad force" 2 "--force: 'spring' is not face, point or pressure" \
	simulate-peer --force 'spring faces=1' s3.tgrid -o o.tgrid
expect_error "face outside the grid" 2 'force 1: face 9999 is outside 0..255' \
	simulate-peer --force 'face faces=9999' s3.tgrid -o o.tgrid
expect_error "frames without a number" 2 'frames: .x.tgrid. needs exactly one %d' \
	simulate-peer --frames x.tgrid s3.tgrid -o o.tgrid
expect_error "frames with an unknown extension" 2 'frames: f0.png: unknown extension' \
	simulate-peer --frames 'f%d.png' s3.tgrid -o o.tgrid
expect_error "unknown output extension" 2 'o.txt: unknown output extension' \
	simulate-peer s3.tgrid -o o.txt
expect_error "two inputs" 2 "more than one input: 's4.tgrid'" simulate-peer s3.tgrid s4.tgrid
expect_error "--dt auto with an implicit method" 2 'dt auto: trapezoid is stable at any step' \
	simulate-peer -q -i trapezoid s3.tgrid -o o.tgrid
expect_error "--dt auto for euler without damping" 2 'euler has no stable step without damping' \
	simulate-peer -q -i euler -b 0 s3.tgrid -o o.tgrid
expect_error "missing input" 1 'nonexistent.tgrid: cannot open' \
	simulate-peer nonexistent.tgrid -o o.tgrid
expect_error "truncated input" 1 'trunc.tgrid: truncated' simulate-peer trunc.tgrid -o o.tgrid
expect_error "rest grid of another level" 1 's4.tgrid: the rest grid must be level 3' \
	simulate-peer --rest s4.tgrid s3.tgrid -o o.tgrid
expect_error "missing scene" 1 'nothere.scene: No such file' \
	simulate-peer -s nothere.scene s3.tgrid -o o.tgrid
expect_error "bad scene line" 1 "bad.scene:2: integrator: 'leapfrog' is not euler" \
	simulate-peer -s bad.scene s3.tgrid -o o.tgrid
# The options the manual says a scene file cannot hold (it claimed "All
# settings" until 2026-12) are unknown settings there.
notscene=$(sed -n '/^Not from a scene file/,/peers. options\.$/p' "$NDO_ROOT/tools/simulate-peer.1" |
	sed -n 's/^\.BR* \\-\\-\([a-z\\-]*\).*/\1/p' | sed 's/\\//g')
[ "$(echo $notscene)" = "accuracy sleep no-estimate threads max-memory info" ] ||
	fail "the manual's options not from a scene file" "found: '$(echo $notscene)'"
for k in $notscene; do
	printf '%s 1\n' "$k" >k.scene
	expect_error "scene key '$k' (not a scene's setting)" 1 "^simulate-peer: k.scene:1: unknown setting '$k'$" \
		simulate-peer -s k.scene s3.tgrid -o o.tgrid
done
: >notadir
expect_error "unwritable frames (a file where their directory goes)" 1 \
	'notadir/f0.tgrid: cannot create directory notadir: Not a directory' \
	simulate-peer -q --frames 'notadir/f%d.tgrid' s3.tgrid -o o.tgrid
expect_error "diverged" 3 '^simulate-peer: diverged at step [0-9]+ ' \
	simulate-peer -q --dt 0.5 --perturb 1e-3 -n 100 s3.tgrid -o o.tgrid
if [ -e o.tgrid ]; then fail "nothing written" "o.tgrid exists"; else pass "nothing written"; fi
# The energy test's work (docs/simulate-peer.md): each step counts its
# own.  Symplectic Euler: the thesis' figure 5.3 at level 2 at its
# automatic step (a quarter of the force's period), which stopped as
# "diverged" at step 2 until 2026-11-30, runs.  rk4 counts its stages'
# work: with the force at 1.4 Hz and a step of half its period (0.86 x the
# critical step; the force 0 at every step's end, at its peak at the
# stages between), which the power at the steps' ends stopped at step 1
# until 2026-11-30, it runs with the test, its energy bounded; a step far
# above the critical one still diverges.
remesh --shape wavy -l 2 -o wavy2.tgrid
check "symplectic Euler at a quarter of the force's period: not a false alarm" \
	simulate-peer -q -i symplectic-euler -s "$NDO_ROOT/samples/thesis-fig5.3.scene" -t 5 \
	wavy2.tgrid -o o.tgrid
sed 's/frequency=1$/frequency=1.4/' "$NDO_ROOT/samples/thesis-fig5.3.scene" >half.scene
grep -q 'frequency=1.4$' half.scene || fail "the scene at 1.4 Hz" "no force line changed"
if simulate-peer -q -i rk4 -s half.scene --dt 0.357142857142857 -t 5 \
	--log e.csv wavy2.tgrid -o o.tgrid 2>err.log &&
	most=$(awk -F, 'NR > 1 && $4 + $5 > m { m = $4 + $5 } END { print m }' e.csv) &&
	work=$(awk -F, 'NR == 3 { print $6 }' e.csv) &&
	awk -v m="$most" -v w="$work" 'BEGIN { exit !(m > 0.1 && m < 0.2 && w > 0.05) }'; then
	pass "rk4 at half the force's period: runs with the energy test (largest energy $most J, step 1's work $work J)"
else
	fail "rk4 at half the force's period" "exit or energy: ${most:-?} J, work ${work:-?} J; $(head -1 err.log)"
fi
expect_error "rk4 at 2.4 x the critical step: diverged" 3 \
	"^simulate-peer: diverged at step 2 .*step 1 s = 2.41 x the critical step.*: energy .* exceeds 10 × \(initial 0 J \+ input work .* J\); the output was not written$" \
	simulate-peer -q -i rk4 -s half.scene --dt 1 -t 5 wavy2.tgrid -o o.tgrid
rm -f o.tgrid

# --log: its place checked before the work (as -o's), not after the setup
# and --accuracy's pilots; '-' beside a grid on standard output would put
# the CSV and the binary grid in one stream (exit 0 until 2026-12); the
# file of -o or the input would be replaced by the CSV.
expect_error "--log in a missing directory, before the work" 1 \
	'^simulate-peer: --log: cannot write nodir/run\.csv: No such file or directory$' \
	simulate-peer --log nodir/run.csv s3.tgrid -o o.tgrid
expect_error "--log - with the grid on standard output" 2 \
	'^simulate-peer: --log -: the grid goes to standard output too' \
	bash -c 'simulate-peer -q -n 2 --log - s3.tgrid >mixed.out'
expect_error "--log naming the output" 2 '^simulate-peer: --log o\.tgrid: that is the output \(-o\)$' \
	simulate-peer -q -n 2 --log o.tgrid s3.tgrid -o o.tgrid
cp s3.tgrid keep3.tgrid
expect_error "--log naming the input" 2 '^simulate-peer: --log \./keep3\.tgrid: that is the input grid$' \
	simulate-peer -q -n 2 --log ./keep3.tgrid keep3.tgrid -o o.tgrid
if cmp -s s3.tgrid keep3.tgrid && [ ! -e o.tgrid ]; then pass "--log refused: the input kept, nothing written"
else fail "--log refused" "the input changed or o.tgrid written"; fi
if simulate-peer -q -n 2 --log - s3.tgrid -o o.tgrid >log.out 2>err.log &&
	[ "$(head -c 5 log.out)" = "step," ] && [ "$(wc -l <log.out)" -eq 5 ]; then
	pass "--log - with -o FILE: the CSV on standard output"
else fail "--log - with -o FILE" "$(head -1 err.log)"; fi
expect_error "a frame path too long, before the work" 2 \
	'^simulate-peer: --frames: the path for frame 0 is too long$' \
	simulate-peer -q --frames 'f%4090d.tgrid' s3.tgrid -o o.tgrid
rm -f o.tgrid

# A step under the smallest normal double is a step of 0 to the steps
# (they flush subnormal numbers): refused before the run, not "step size
# 1e-310: must be positive and finite" (exit 1) at the first step.
for o in "--dt 1e-320" "-t 1e-310" "--dt-safety 1e-310"; do
	expect_error "a subnormal step ($o)" 2 \
		"^simulate-peer: the step [0-9.e+-]+ s is under 2\.2e-308 s, the smallest normal double" \
		simulate-peer -q $o s3.tgrid -o o.tgrid
done
# A density whose nodes' masses are not normal doubles: 1/m overflowed,
# and --info said "rk4: stable at any step".
expect_error "a density too small for the doubles" 1 \
	"density 1e-310: node \(0, 0\)'s mass [0-9.e+-]+ kg is too small for a double's range \(its inverse overflows\)" \
	simulate-peer --info --density 1e-310 s3.tgrid
# --rest - beside an input on standard input: one grid there, the input's
# (the rest grid, read after it, found "standard input: empty input").
expect_error "--rest - with the input on standard input" 2 \
	"^simulate-peer: --rest -: standard input holds the input grid" \
	bash -c 'simulate-peer -q -n 2 --rest - <s3.tgrid >o.tgrid'
if simulate-peer -q -n 2 --rest - s3.tgrid -o o.tgrid <s3.tgrid 2>err.log; then
	pass "--rest - with the input a file"
else fail "--rest - with the input a file" "$(head -1 err.log)"; fi
rm -f o.tgrid
# A force's direction is any nonzero finite vector: one whose components'
# squares leave the doubles (1e-300,0,0: length 0; 1e200,0,0: inf) was
# refused as "must be a nonzero finite vector"; it is the same run as 1,0,0.
for d in 1,0,0 1e-300,0,0 1e200,0,0; do
	simulate-peer -q -n 4 --force "point nodes=3:3 direction=$d" --log "dir-$d.csv" s3.tgrid \
		-o o.tgrid 2>err.log || fail "direction $d" "$(head -1 err.log)"
done
if cmp -s dir-1,0,0.csv dir-1e-300,0,0.csv && cmp -s dir-1,0,0.csv dir-1e200,0,0.csv; then
	pass "tiny and huge force directions: the unit direction's run"
else fail "tiny and huge force directions" "the logs differ from direction=1,0,0's"; fi
rm -f o.tgrid
