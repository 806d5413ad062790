#!/usr/bin/env bash
# tests/bench/multigrid.sh — the implicit methods' solvers: conjugate
# gradients with the multigrid V-cycle (--solver multigrid) against CHOLMOD
# (--solver cholmod): steps/s at levels 5-8 on one and on two threads, the
# difference of the steps, iterations per solve at levels 4-10, and peak
# memory at levels 8-10.  Writes docs/bench/multigrid.md.  About 10 minutes.
set -euo pipefail
cd "$(dirname "$0")/../.."
B=${NDO_TESTBIN:-build/tests}
out=docs/bench/multigrid.md
mkdir -p docs/bench build/bench
t=build/bench/multigrid
load0=$(cut -d' ' -f1-3 /proc/loadavg)
# MG_PARTS="speed" measures only the speed tables (the iterations and the
# memory, which the load does not change, are taken from the last run's
# files under build/bench/ when present)
want() { [[ " ${MG_PARTS:-speed iters memory} " == *" $1 "* ]] || [ ! -s "$t-$1.md" ]; }
ran="" # the parts this run measured
if want speed || [ ! -s "$t-speed2.md" ]; then
	"$B/bench_multigrid" speed 5 6 7 8 >"$t-speed.md"
	"$B/bench_multigrid" -t 2 speed 8 >"$t-speed2.md"
	echo "$load0 at the start and $(cut -d' ' -f1-3 /proc/loadavg) at the end" >"$t-speed.load"
	ran="$ran speed"
fi
if want iters; then
	"$B/bench_multigrid" iters 0.01 0.1 1.0 4 5 6 7 8 9 10 >"$t-iters.md"
	ran="$ran iters"
fi
want memory && ran="$ran memory" && {
	echo "| level | nodes | method | solver | step (s) | peak RSS (MiB) | estimate (MiB) | s/step | iterations/solve |"
	echo "|---:|---:|---|---|---:|---:|---:|---:|---:|"
	for l in 8 9 10; do
		for s in multigrid cholmod; do
			"$B/bench_multigrid" memory $l backward-euler $s 0.01
		done
	done
} >"$t-memory.md.new" && mv "$t-memory.md.new" "$t-memory.md"
load1=$(cut -d' ' -f1-3 /proc/loadavg)
# this machine's caches and the triad over level 8's size (the solve's
# arrays are about 25 MB there), for the summary's bytes an iteration
l2=$(lscpu | sed -n 's/^L2 cache: *//p' | head -1)
l3=$(lscpu | sed -n 's/^L3 cache: *//p' | head -1)
"$B/bench_simulate" bandwidth 2 >"$t-bandwidth.md"
bw1="" bw2="" # (the summary says "?" without them: set -e must not end the report here)
read -r bw1 bw2 < <(awk -F'|' '$2 ~ /24.00 MiB/ { print $4 + 0, $5 + 0 }' "$t-bandwidth.md") || true
# the tables this run did not measure (MG_PARTS left them out and their
# files were there), and when they were
old=""
for p in speed iters memory; do
	[[ "$ran " == *" $p "* ]] ||
		old="$old${old:+; }the $p table from $(date -u -r "$t-$p.md" '+%F %H:%M UTC')$(
			[ $p != speed ] || [ ! -s "$t-speed.load" ] || echo ", load average $(cat "$t-speed.load")")"
done

# The goal: backward Euler and trapezoid at level 8 ≥ 10× the CHOLMOD
# figures of docs/bench/simulate.md (11.01 and 14.55 steps/s), and the ratio
# within this run.
row() { awk -F'|' -v m="$2" -v c="$3" '$2 ~ " "m" " && $3 == " 8 " { gsub(/ /, "", $c); print $c }' "$1"; }
summary=$(awk -v be1="$(row "$t-speed.md" backward-euler 7)" -v tr1="$(row "$t-speed.md" trapezoid 7)" \
	-v beq="$(row "$t-speed.md" backward-euler 8)" -v trq="$(row "$t-speed.md" trapezoid 8)" \
	-v be2="$(row "$t-speed2.md" backward-euler 7)" -v tr2="$(row "$t-speed2.md" trapezoid 7)" \
	-v beq2="$(row "$t-speed2.md" backward-euler 8)" -v trq2="$(row "$t-speed2.md" trapezoid 8)" 'BEGIN {
	printf "- Goal: backward Euler and trapezoid at level 8 at 10× the steps/s of CHOLMOD (docs/bench/simulate.md: 11.01 and 14.55).  Measured, one thread: **%.3g and %.3g steps/s, %.2f× and %.2f× CHOLMOD** run alternately with it in this run (%.1f× and %.1f× the recorded figures, measured on another day, under another load); two threads: %.3g and %.3g steps/s, %.2f× and %.2f× CHOLMOD (on one; %.1f× and %.1f× the recorded figures): %s.  Two threads against one, each through the CHOLMOD runs paired with it (the ratio of the ratios: the machine'"'"'s load changes between the two tables, and the steps/s with it): backward Euler %.2f×, trapezoid %.2f×.\n",
		be1, tr1, beq, trq, be1 / 11.01, tr1 / 14.55, be2, tr2, beq2, trq2, be2 / 11.01, tr2 / 14.55,
		(beq2 >= 10 && trq2 >= 10) ? "met" : "NOT met", beq2 / beq, trq2 / trq
}')

{
	echo "# Implicit steps: multigrid against CHOLMOD"
	echo
	echo "Made by \`tests/bench/multigrid.sh\` (\`tests/bench/run multigrid\`) on $(date -u +%F), $(nproc) cores ($(lscpu | sed -n 's/^Model name: *//p' | head -1)), load average $load0 at the start and $load1 at the end (the machine is shared: medians of 7 runs; the solvers' runs alternate and each ratio is the median of the 7 pairs' ratios)."
	echo
	[ -z "$old" ] || printf 'Not measured in this run (MG_PARTS="%s"): %s.\n\n' "$MG_PARTS" "$old"
	# under load: this run's, or the speed tables' run where this one did not measure them
	chk="$load0 $load1"
	[[ " ${MG_PARTS:-speed iters memory} " == *" speed "* ]] || [ ! -s "$t-speed.load" ] ||
		chk=$(awk '{ print $1, $2, $3, $8, $9, $10 }' "$t-speed.load")
	awk -v l="$chk" 'BEGIN { split(l, a, " "); if (a[1] > 1.5 || a[4] > 1.5) print "Taken under load (other work shared the 2 cores): the steps/s are low and noisy, the ratios within a pair of runs mean more; the figures of a quiet machine replace these when the lead reruns the benchmark.\n" }'
	echo "## Summary"
	echo
	echo "$summary"
	# figures of this run for the two paragraphs below
	it() { awk -F'|' -v l="$2" -v c="$3" '$2 == " "l" " { split($c, a, " "); print a[1] }' "$t-iters.md"; }
	jac=$(awk -F'|' '$3 == " 8 " && $9 ~ /Jacobi/ { v = $10 + 0; if (lo == "" || v < lo) lo = v; if (v > hi) hi = v }
		END { printf "%.1f–%.1f", lo, hi }' "$t-speed.md")
	echo "- Why not 10×: near the explicit limit (the benchmark's step, half RK4's) the system is mass-dominated (D⁻¹A's spectrum about [0.7, 1.3] at level 8, condition number about 2) and conjugate gradients with Jacobi need $jac iterations a solve (this run) to the relative residual of 10⁻¹² (\`NDO_SOLVER_TOL\`: the trapezoid damps no error, so a looser stop adds up over a run, docs/peers.md) from an extrapolated first guess.  An iteration is three passes over the rows: the product A p (the regular rows' stencil without indices: 41 bytes a row, p and q: 89 bytes), the update of x and r with two sums (152 bytes) and the new direction from r, D⁻¹ and p (80 bytes; z is not stored): 321 bytes a row, 42 MB an iteration at level 8, and a solve adds two residuals and a start (about 300 bytes a row).  At level 8 that is about 400 MB a step, which at 110 steps/s is 44 GB/s; the solve's arrays (about 25 MB besides the CSR copy) are larger than a core's L2 (\`lscpu\`: L2 ${l2:-?}, L3 ${l3:-?}, the L3 shared with the host's other work), so at level 8 an iteration streams from the shared cache or memory: 42 MB at this run's triad over 24 MiB, ${bw1:-?} GB/s on one thread and ${bw2:-?} on two (\`bench_simulate bandwidth 2\`), is $(awk -v a="${bw1:-0}" -v b="${bw2:-0}" 'BEGIN { if (a > 0 && b > 0) printf "%.1f and %.1f ms", 42 / a, 42 / b; else printf "? ms" }'), and 10× (110–146 steps/s at 6–9 iterations a step) would need about 40 GB/s$(awk -v b="${bw2:-0}" 'BEGIN { if (b >= 40) printf ", which two threads have here: on two threads the streams alone do not bound it (the passes timed below, on an earlier host, put the rest in the product'"'"'s loads, the update'"'"'s shared bandwidth and the hand-overs to the pool)" }').  Since 2026-11-29 (evening) the update takes four rows at a time with its sums in vector lanes (it had six chains of dependent additions): \`bench_multigrid steps\`, 9 alternating pairs, CPU time 0.93× (level 6, backward Euler) and 0.96× (level 7, trapezoid) of the build before, level 8 unchanged.  Measured with a temporary timer on one thread (load 0.9, before the vector loads and with z stored): the product 884 µs, the update 511 µs, the direction 98 µs (96 GB/s: the streaming passes run at the cache's speed, the product at a third of it, bound by its loads); on two threads (load 0.9) the product took 596 µs (1.8×), the update 446 µs (1.16×: the shared cache's bandwidth) and the direction 153 µs, slower than on one (handing a loop to the pool and waking it costs about as much as that pass: three loops an iteration).  Tried and not kept: Chebyshev iteration (one pass and no sums an iteration) needed 21.8 and 11.4 iterations on Gershgorin's interval [0.35, 1.65] and 11.7 and 11.9 on the measured [0.69, 1.31], against CG's 8.7 and 5.9; a quadratic extrapolation of the acceleration for the first guess saved 0.3 iterations (backward Euler 8.7 → 8.4, trapezoid 5.9 → 5.7) for one more stream, and adding the last step's correction to the guess moved them by ±0.2; the new direction computed inside the next product (z + βp of the neighbours again: two passes an iteration instead of three) was 10–30% slower on one thread (task-clock of 200 fixed steps, alternating, load 6–9: twice the loads in the product); not measured on two threads, where it saves a pass and a hand-over to the pool.  A coarse-grid correction does not pay either (3.8 V-cycle iterations cost 1.6× of 12.6 Jacobi ones).  Tried on 2026-11-25 (load 7–13, so as ratios): the trapezoid's two-thread gain of 1.18× in the table of that morning was the load, not the code (CHOLMOD, on one thread in both tables, went from 16.2 to 12.1 steps/s between them; through the paired ratios the gain was 1.57×, backward Euler's 1.64×); a better preconditioner without a hierarchy, the first two terms of the Neumann series of A⁻¹, 2D⁻¹ − D⁻¹AD⁻¹ (positive definite where Gershgorin's bound on D⁻¹A is below 2; M⁻¹A's spectrum λ(2 − λ) ∈ [0.90, 1] for λ ∈ [0.69, 1.31]), cut the iterations from 7.9 to 4.7 (backward Euler) and 5.5 to 3.1 (trapezoid) but not the time (CPU seconds of 150 steps 0.985× Jacobi's, 7 alternating pairs; samples in the CG's loops −2%): it adds a product an iteration, and the product, not the streams, is what an iteration costs — 884 µs for 131,074 rows, about 20 cycles a row (13 GB/s against the streaming passes' 96 GB/s), bound by its loads, about 17 a row (7 of x, 7 coefficients, the offsets and the flag; two partial sums instead of one chain of 7 additions changed nothing measurable).  Not kept.  Not tried: float vectors with refinement in double, which halve the streams' bytes but not the product's loads, and restart the Krylov space at every refinement.  CHOLMOD's solve is two triangular sweeps over a factor of 8.1 million nonzeros.  The multigrid pays most where CHOLMOD is weakest: large steps on fine levels (iterations below) and memory."
	echo "- The product by runs (2026-11-25, load 1–5, so as ratios): \`perf record\` / \`perf annotate\` of 100 backward-Euler steps at level 8 (no hardware counters on this VM: timer samples) put two thirds of the samples in the solver's loops, and in the product's loop the loads of the row's flag, offsets and 14 operands.  Now the regular rows are read by runs with the same offsets (a run length a row, found at setup): a row's left, own and right values of x, the second of its lower and upper pairs and its left coefficient are the row before's, so a row loads 3 vectors of x and 6 coefficients (was 7, 7, the flag and 2 offsets), and the residual or p·Ap is taken on the row as it is computed; the same products and sums in the same order: the same bits as before (test_multigrid's CSR comparison, and \`bench_multigrid steps\`' hash of the velocities, equal for the two builds and for 1 and 2 threads).  Steps per CPU second, \`bench_multigrid steps 8 METHOD 150\` of this build and of the one before (a454be7), 7 alternating pairs, median of the pairs' ratios: one thread backward Euler 1.10× (60.8 against 56.9) and trapezoid 1.09× (70.0 against 64.0), in an earlier run 1.12× and 1.11× (load 4.6–5.2), and at load 1.1–1.2 (after the two loops became one, 900dcde) only 1.05× and 1.07× (66.8 against 63.7, 66.5 against 64.2): the fewer loads matter more when the cache is shared; two threads (5 pairs) 0.99× and 1.05× (CPU time: the pool's hand-overs weigh more there).  A first version that scanned for the runs' ends at every pass and summed in a second loop over the run was 0.93×.  With Jacobi alone the start no longer writes z (3 MB a solve at level 8).  The Neumann preconditioner again on this product (\`NDO_MG_NEUMANN\`, a patch not kept): iterations 9.3 → 5.1 (backward Euler) and 6.0 → 3.6 (trapezoid), with D⁻¹r stored by the update pass and the second product fused with z = D⁻¹(2r − A D⁻¹r) and r·z, CPU time per step 0.998× and 0.979× Jacobi's the same way (0.92× and 0.95× with D⁻¹r in a pass of its own): still break-even, as the product still costs most of an iteration.  Not kept."
	echo "- Tried on 2026-11-25, 16:35–17:05 UTC (load 6–11: as ratios of alternating runs of two builds, \`bench_multigrid steps 8 METHOD 150\`, steps per CPU second, unless said otherwise), none kept.  Where the time of a step goes (\`perf record\` of 300 steps at level 8, one thread, load 8): the solver's loops 68% of the samples (backward Euler) and 64% (trapezoid), the right-hand side's and the update's passes over the rows (implicit.c) 12% and 15%, the forces and their preparation about 11%: 10× on one thread (1.75× today's steps/s) would need the solver about 2.6× faster.  The mixed-precision V-cycle does not apply to the goal: at half RK4's step the stiffness part of the diagonal stays below THETA × the mass part and the hierarchy is Jacobi alone (*levels* 1 in the speed tables), so no V-cycle runs; where it runs (the fixed steps of the iteration table) it was not tried.  Conjugate gradients in Chronopoulos and Gear's form (one point of inner products an iteration: the product w = A z with z·w, then one pass for the directions p = z + βp, s = w + βs, the iterate and z = D⁻¹r kept for r, with r·z and |r|²; two passes an iteration instead of three, the same bytes): the same iterations (7.49 and 5.25 a solve), one thread 0.93× (backward Euler) and 0.92× (trapezoid), 3 pairs; whole processes (\`farm-bench\`, 7 pairs, set-up included) CPU 0.97× and 0.95×; two threads' wall time 0.94× (5 pairs at load 10: the two threads waited for the cores, not conclusive).  The product 4 rows at a time as 12 flat values (each coefficient loaded once for 4 rows and spread over 3 vectors, the operands loaded as they lie, every value's 7 products in CSR's order: the same bits as CSR, the sums in another order): 0.88× and 0.85× (7 pairs): 7 unaligned operand loads and 3 spreads a row lose to the runs' 3 loads carried from row to row.  The passes of implicit.c with one loop a case (no tests inside) and compiled for x86-64-v3 as well: the same bits, their share of the samples 14.9% → 14.4%: nothing; the rigid correction's sums of v, f and the mass taken in the right-hand side's pass, which reads those rows already, leaving its own pass the solution's sum alone (the same bits): 0.94× (trapezoid) and 0.99× (7 pairs, load 6–8).  For scale, not applied: \`NDO_SOLVER_TOL\` at the issue's 10⁻¹⁰ instead of 10⁻¹² (a build for the measurement) takes 5.45 and 4.11 iterations a solve (7.49 and 5.25) and runs 1.22× (backward Euler) and 1.11× (trapezoid) as fast (5 pairs, load 6–7); the trapezoid needs 10⁻¹² (docs/peers.md: it damps no error, and at 10⁻¹⁰ drifted to 4.9·10⁻¹⁰ of CHOLMOD's run in 10 s); nor may backward Euler, which damps: stopped at 10⁻¹⁰ (a build for the measurement, 2026-11-30), its 10 s of the thesis scene at level 6 (h = 0.0106 s, 944 steps) ended 2.3·10⁻¹⁰ of the largest displacement from CHOLMOD's, against 8.9·10⁻¹³ at 10⁻¹², above the 10⁻¹⁰ that peers' runs are held to (docs/peers.md); the trapezoid's 8.1·10⁻¹² either way.  With two threads, the direction pass on the calling thread alone: wall time 0.97× (7 pairs at load 8, spread 0.72–1.14×: not conclusive)."
	echo "- Tried on 2026-12-01, 05:05–05:50 UTC (load 3–4 throughout: other work on both cores, so as ratios of alternating runs of two builds, \`bench_multigrid [-t 2] steps 8 METHOD N\`, which now prints wall-clock steps/s and the steps run alone beside steps per CPU second; the same velocities' hash for every build below, on 1–3 threads).  **Kept: the solver runs alone when the step does.**  The look at whether the threads pay (lib/sim/integrate.c, threads_pick: steps alternately alone and on the threads, then the faster way) could not work for the implicit methods: the multigrid solver, two thirds of a step, kept the pool it was made with, so a step alone ran its solve on the threads all the same.  At this load two threads ran level 8 at 0.81× one thread's wall speed (backward Euler, 7 alternating pairs of 80 steps, range 0.62–0.95, the look answering threads), and the same binary with every step forced alone (a build for the measurement) at 0.92–1.01× (4 pairs).  Now the solver takes the step's choice (ndo__mg_set_pool, the same bits): two threads' wall time against the build before, backward Euler 1.06× (11 pairs of 80 steps, range 0.85–1.44) and 1.04× (9 pairs, 0.52–1.30), trapezoid 1.05× (11 pairs, 0.82–1.31) and 1.02× (9 pairs, 0.88–1.60); a quiet machine's figures (the tables below) should not move, its looks answering threads (not measured: no quiet machine that day).  **Kept: Jacobi CG's first direction in the first residual's pass** (p = D⁻¹r and r·D⁻¹r as the residual is computed: one pass and one hand-over a solve fewer): \`valgrind --tool=callgrind --toggle-collect=ndo__mg_solve --cache-sim=yes --LL=2097152,16,64 bench_multigrid steps 8 trapezoid 8\` (13 solves): 5.3% fewer instructions in the solver (1.112·10⁹ against 1.174·10⁹) and 1.3% fewer misses of a simulated 2 MiB L2 (46.7 against 47.3 million); wall and CPU time at this load 1.00× (trapezoid) and 1.05× (backward Euler), 11 pairs each, ranges 0.74–1.44: below the noise.  Not kept: the new direction made inside the next product without loading it twice (each chunk computes p′ = D⁻¹r + βp once a row over its rows and the 512 rows each side that its stencil reads, into a scratch per thread of 123 KB, its own rows also into a second p array, and runs the product from the scratch: two passes and two hand-overs an iteration instead of three): one thread 0.79× (7 pairs), 0.88× with that loop four rows at a time (5 pairs), two threads 0.85× CPU and wall (7 pairs): the second array's writes and the 25% of rows computed twice move about 118 bytes a row where the two passes move 104.  The pool's chunks in one contiguous range a thread (its own first, then the others': a chunk stays on a core from pass to pass): two threads' wall time 1.09× and 0.99× (7 pairs each), 1.00× (15 pairs), 0.99× (11 pairs), CPU 1.01–1.03×: nothing at this load (a core's L2, 2 MiB, holds little of an iteration's ~10 MB a thread).  The regular rows' four coefficient arrays interleaved into one stream: 1.01× (9 pairs).  multigrid.c at -O3: 0.99× (9 pairs).  The flags: the CG loops already build for x86-64 and x86-64-v3 (target_clones, NDO_MG_HOT) under -std=c11, where GCC forms no fused multiply-add (-ffp-contract=off in ISO C mode), so both clones give the same bits. Both kept changes together against the build before (9 alternating pairs of 80 steps each, load 2.3–6.8): two threads' wall time 1.02× (backward Euler) and 0.98× (trapezoid), one thread's 1.06× and 1.13×, every range wider than 0.63–1.39: within this load's noise, not a measured speed-up."
	echo "- Iterations per solve at a fixed step, where the V-cycle runs, grow slowly with the level and level off (at 0.1 s: $(it x 5 5) at level 5, $(it x 8 5) at 8, $(it x 10 5) at 10; at 1 s: $(it x 5 6) to $(it x 10 6)), where Jacobi alone would double a level; in the Jacobi regime they stay below about 20 (the hierarchy starts where the stiffness passes 12× the mass).  Nearly, not exactly, level-independent: each level adds a smoothing error the degree-2 smoother does not remove.  CHOLMOD's factor grows faster than the nodes (8.1 million nonzeros at level 8, 135 million at 10) and its factorization faster still."
	echo
	echo "## Steps per second, one thread"
	echo
	echo "The thesis scene (figure 5.3: the wavy surface, k = 1 N/m, b = 0.1, a 2.4 N sinusoidal force on the faces around (0, 0, 1)) at half RK4's critical step.  *levels*: the hierarchy's (1: Jacobi alone); *step difference*: the largest difference of the velocities after 20 steps with each solver, relative to the largest velocity."
	echo
	cat "$t-speed.md"
	echo
	echo "## Level 8 on two threads"
	echo
	echo "The same, \`bench_multigrid -t 2 speed 8\` (CHOLMOD's solve stays on one thread; the multigrid's loops run over fixed chunks of 4,096 rows, the same bits on any thread count)."
	echo
	cat "$t-speed2.md"
	echo
	echo "## Iterations per solve against the level"
	echo
	echo "Backward Euler on the thesis scene, 5 steps of each size from rest; in brackets the hierarchy's levels (j: none, Jacobi alone: the mass dominates).  At a fixed step the stiffness grows 4× a level relative to the mass; Jacobi's iterations would double a level."
	echo
	cat "$t-iters.md"
	echo
	echo "## Memory"
	echo
	echo "Three backward-Euler steps of 0.01 s, one process each; *peak RSS* less the grid's; *estimate*: what \`--max-memory\` checks before allocating (\`ndo_sim_memory\`; for CHOLMOD the arrays only — the factor is sized by its analysis and checked then: at level 10, 135 million nonzeros, 2.2 GB in all).  *s/step* includes building the hierarchy or the factor."
	echo
	cat "$t-memory.md"
	echo
	echo "Regenerate: \`make -j2 && tests/bench/run multigrid\`."
} >"$out"
cat "$out"
