#!/usr/bin/env bash
# The owner's death over real LCM in a private network namespace
# (docs/peers.md, "The owner's death"): the owner and 2 joiners, lock-step
# rk4, the thesis' scene (figure 5.3) at level 4, the owner killed with
# SIGKILL at a random moment of the run: the first joiner of its partition
# succeeds it, restarts the others from a checkpoint and writes its -o, the
# single process's bit for bit, with and without 10 % loss; an observer
# follows the successor (and, like it, does not say "NOT exact": a taint
# it heard was undone by the restart); a successor without -o says the result has nowhere
# to go; render-frame --lcm follows the successor to the last step; and
# the owner killed after its joiners' last step, before it gathered, is
# succeeded all the same.  (peers-restart.sh kills joiners.)
. "$(dirname "$0")/netns.bash"
. "$(dirname "$0")/lib.sh"
. "$(dirname "$0")/peers.bash"

SCENE=$NDO_ROOT/samples/thesis-fig5.3.scene
remesh --shape wavy -l 4 -o wavy4.tgrid 2>/dev/null || fail "remesh"
RUN=(-s "$SCENE" --dt 0.005 -t 80)
SOLO=solo.tgrid
simulate-peer -q wavy4.tgrid "${RUN[@]}" -o $SOLO 2>solo.err || fail "single process"

# start3 OUT1 OUT2 [options for every peer...]: the owner and 2 joiners in
# the background (pids: owner, j1, j2), joiner k with -o OUTk where OUTk is
# not empty.
start3() {
	local o1=$1 o2=$2
	shift 2
	rm -f owner.err joiner1.err joiner2.err
	simulate-peer --owner wavy4.tgrid "${RUN[@]}" --peers 3 --peer-timeout 1 --step-timeout 0.2 \
		--start-timeout 30 -o peers.tgrid "$@" 2>owner.err &
	owner=$!
	simulate-peer --join --poi 300 --peer-timeout 1 --start-timeout 30 ${o1:+-o "$o1"} "$@" \
		2>joiner1.err &
	j1=$!
	simulate-peer --join --poi 900 --peer-timeout 1 --start-timeout 30 ${o2:+-o "$o2"} "$@" \
		2>joiner2.err &
	j2=$!
}

# kill_owner NAME [PID...]: once the run has started, SIGKILL on the owner after
# a pause, and the joiners' exit statuses (r1, r2).  When the run does not
# start: NAME fails, every peer and PID is killed, status 1.
kill_owner() {
	local name=$1
	shift
	if ! wait_for owner.err 'starting: step' 30 >/dev/null; then
		fail "$name" "the run did not start"
		kill $owner $j1 $j2 "$@" 2>/dev/null
		wait
		return 1
	fi
	pause
	{ kill -KILL $owner && wait $owner; } 2>/dev/null
	wait $j1; r1=$?
	wait $j2; r2=$?
}

# owner_killed NAME [options for every peer...]: the owner and 2 joiners
# (each joiner with its own -o), the owner sent SIGKILL after a pause: the
# first joiner of its partition owns the session once the owner has been
# silent for --peer-timeout, restarts every survivor from the newest step it
# holds whole (every simulating peer keeps every peer's checkpoints), gathers
# the last step and writes its -o: the single process's bit for bit; the
# other joiner ends with exit status 0 when the successor quits.  An
# observer (no --poi) follows the successor too: its -o is the same.
owner_killed() {
	local name=$1 obs
	shift
	rm -f heir1.tgrid heir2.tgrid observed.tgrid obs.err
	start3 heir1.tgrid heir2.tgrid "$@"
	simulate-peer --join --peer-timeout 1 --start-timeout 30 -o observed.tgrid "$@" 2>obs.err &
	obs=$!
	# the observer observing before the kill: on a loaded machine it may
	# still be taking the object in when the pause ends, and an observer
	# that holds the object but has not started when the owner dies does
	# not always follow the successor (docs/peers.md, "Not done"; an
	# observer still taking the description in does: test_peer
	# an_observer_on_its_way_follows_the_successor)
	wait_for obs.err 'observing from step' 30 >/dev/null ||
		echo "    (the observer was not observing within 30 s)" >&2
	kill_owner "$name" $obs || return
	local ro heir= same ostep
	wait $obs; ro=$?
	grep -q 'owns the session now (this one)' joiner1.err && heir=1
	grep -q 'owns the session now (this one)' joiner2.err && heir=${heir:+both}${heir:-2}
	local at rel owners step sstep
	if [ "$heir" = 1 ] || [ "$heir" = 2 ]; then
		at=$(grep -o 'restarting from step [0-9]*.*again' joiner$heir.err | tail -1)
		read -r rel owners step sstep < <(compare heir$heir.tgrid "$SOLO")
		read -r same _ ostep _ < <(compare observed.tgrid heir$heir.tgrid)
	fi
	if [ $r1 = 0 ] && [ $r2 = 0 ] && [ "${rel:-}" = 0 ] && [ "$step" = "$sstep" ] &&
		! grep -q 'NOT exact' joiner$heir.err obs.err && [ $ro = 0 ] && [ "${same:-}" = 0 ] &&
		[ "$ostep" = "$sstep" ]; then
		pass "$name: joiner $heir took over, ${at:-no restart}; its -o differs from the single process by $rel ($owners owners at the end), the observer's -o from it by $same"
	else
		fail "$name" "joiner exits $r1 $r2, observer $ro, successor ${heir:-none}, difference ${rel:-?}, step ${step:-?} of ${sstep:-?}, the observer's -o from the successor's ${same:-?}"
		tail -4 joiner1.err | sed 's/^/    joiner 1: /'
		tail -4 joiner2.err | sed 's/^/    joiner 2: /'
		tail -3 obs.err | sed 's/^/    observer: /'
	fi
}
owner_killed "SIGKILL on the owner"
# (under loss a lost halo costs a re-send, 10 ms: 16000 steps took 40 s, 4000
# still take 5 s or more, long enough for the kill to come first)
RUN=(-s "$SCENE" --dt 0.005 -t 20)
SOLO=solo20.tgrid
simulate-peer -q wavy4.tgrid "${RUN[@]}" -o $SOLO 2>>solo.err || fail "single process, 20 s"
owner_killed "SIGKILL on the owner, 10% loss" --drop 0.1

# joiners without -o: the successor gathers the result and says it has nowhere
# to write it (exit 0), the other joiner ends with exit 0
RUN=(-s "$SCENE" --dt 0.005 -t 80)
name="the owner killed, no joiner with -o"
start3 "" ""
if kill_owner "$name"; then
	said=$(grep -l 'has no -o to write it to' joiner1.err joiner2.err | wc -l)
	if [ $r1 = 0 ] && [ $r2 = 0 ] && [ "$said" = 1 ]; then
		pass "$name: the successor says the result has nowhere to go"
	else
		fail "$name" "exits $r1 $r2, $said successors said so"
		tail -3 joiner1.err | sed 's/^/    joiner 1: /'
		tail -3 joiner2.err | sed 's/^/    joiner 2: /'
	fi
fi

# render-frame --lcm follows the successor: drawing every 2000th step live, it
# draws the last one (16000) and ends when the successor ends the session
name="render-frame through the owner's death"
mkdir -p live
render-frame --lcm default --every 2000 -s 64x48 -o 'live/f%05d.png' 2>live.err &
live=$!
sleep 0.3 # listening before the owner speaks
start3 heir1.tgrid heir2.tgrid
if kill_owner "$name" $live; then
	wait $live; rl=$?
	if [ $r1 = 0 ] && [ $r2 = 0 ] && [ $rl = 0 ] && [ -s live/f16000.png ]; then
		pass "render-frame --lcm follows the owner's successor: $(ls live | wc -l) frames, the last step's among them"
	else
		fail "$name" "joiner exits $r1 $r2, render-frame $rl, frames: $(ls live | tr '\n' ' ')"
		tail -3 live.err | sed 's/^/    render-frame: /'
	fi
fi

# After the joiners' last step, before the owner gathered: the owner hears
# the others 1.5 s late (--delay, on what it receives), so the joiners finish
# 4 steps while it still waits for their third; the kill comes once joiner
# 1's frame of the last step is written.  Its successor restarts from a
# checkpoint (the first step, level 4: every 20), gathers and writes the
# single process's -o.  Until 2026-11-30 the joiners took the silence there
# for the session's end (exit 0) and the result died with the owner.
name="the owner killed after the joiners' last step"
RUN=(-s "$SCENE" --dt 0.005 -t 0.02)
simulate-peer -q wavy4.tgrid "${RUN[@]}" -o solo4.tgrid 2>>solo.err || fail "single process, 4 steps"
rm -rf late heir1.tgrid heir2.tgrid
simulate-peer --owner wavy4.tgrid "${RUN[@]}" --peers 3 --delay 1500 --peer-timeout 3 \
	--step-timeout 5 --start-timeout 30 -o peers.tgrid 2>owner.err &
owner=$!
simulate-peer --join --poi 300 --peer-timeout 3 --start-timeout 30 -o heir1.tgrid \
	--frames 'late/f%03d.tgrid' 2>joiner1.err &
j1=$!
simulate-peer --join --poi 900 --peer-timeout 3 --start-timeout 30 -o heir2.tgrid 2>joiner2.err &
j2=$!
if ! wait_for late/f004.tgrid '' 30 >/dev/null; then
	fail "$name" "joiner 1 did not write its last step's frame"
	kill $owner $j1 $j2 2>/dev/null
	wait
else
	{ kill -KILL $owner && wait $owner; } 2>/dev/null
	wait $j1; r1=$?
	wait $j2; r2=$?
	heir=
	grep -q 'owns the session now (this one)' joiner1.err && heir=1
	grep -q 'owns the session now (this one)' joiner2.err && heir=${heir:+both}${heir:-2}
	gathered=$(grep -c 'done' owner.err)
	read -r rel _ step sstep < <(compare heir${heir:-1}.tgrid solo4.tgrid)
	if [ "$gathered" = 0 ] && [ $r1 = 0 ] && [ $r2 = 0 ] && { [ "$heir" = 1 ] || [ "$heir" = 2 ]; } &&
		[ "${rel:-}" = 0 ] && [ "$step" = "$sstep" ]; then
		pass "$name: joiner $heir took over, $(grep -o 'restarting from step [0-9]*' joiner$heir.err | tail -1); its -o differs from the single process by $rel"
	else
		fail "$name" "the owner done before the kill: $gathered; joiner exits $r1 $r2, successor ${heir:-none}, difference ${rel:-?}, step ${step:-?} of ${sstep:-?}"
		tail -4 joiner1.err | sed 's/^/    joiner 1: /'
		tail -4 joiner2.err | sed 's/^/    joiner 2: /'
	fi
fi
