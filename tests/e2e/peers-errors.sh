#!/usr/bin/env bash
# The peers' options refused with one line and exit 2, before any network
# traffic: a joiner does not take physics, input or the owner's choices;
# values out of range; peer options without a role; render-frame's LCM
# options.
. "$(dirname "$0")/lib.sh"

remesh --shape sphere -l 3 -o s3.tgrid 2>/dev/null || fail "remesh"

expect_error "--owner and --join" 2 'one or the other' simulate-peer --owner --join s3.tgrid
expect_error "a joiner with an input" 2 "s3.tgrid': a joiner receives the object" \
	simulate-peer --join s3.tgrid
expect_error "a joiner with physics" 2 '^simulate-peer: --stiffness: a joiner takes the physics' \
	simulate-peer --join -k 2
expect_error "a joiner with a scene" 2 '^simulate-peer: --scene: a joiner takes the physics' \
	simulate-peer --join -s "$NDO_ROOT/samples/thesis-fig5.3.scene"
expect_error "a joiner choosing the clock" 2 '^simulate-peer: --clock: the owner decides it' \
	simulate-peer --join --clock realtime
expect_error "peer options alone" 2 'the peers. options need --owner or --join' \
	simulate-peer --poi 3 s3.tgrid
expect_error "--drop out of range" 2 '--drop' simulate-peer --owner s3.tgrid --drop 1.5
expect_error "--peers out of range" 2 '--peers' simulate-peer --owner s3.tgrid --peers 9
expect_error "--partition unknown" 2 "--partition: 'spiral' is not quadtree, table41 or metis" \
	simulate-peer --owner s3.tgrid --partition spiral
expect_error "--clock unknown" 2 "--clock: 'wall' is not lockstep or realtime" \
	simulate-peer --owner s3.tgrid --clock wall
expect_error "--boundary unknown" 2 "--boundary: 'fixed' is not exact, extrapolate or hold" \
	simulate-peer --owner s3.tgrid --boundary fixed
expect_error "--channel with a regex" 2 "--channel: 'A.B'" simulate-peer --owner s3.tgrid --channel A.B
expect_error "--poi beyond the grid" 2 '--poi: face 256 is outside 0..255 for a level-3 grid' \
	simulate-peer -q --owner s3.tgrid --poi 256 -o x.tgrid

expect_error "render-frame: --lcm not a URL" 2 "--lcm: 'run.lcmlog' is not udpm://" \
	render-frame --lcm run.lcmlog -o x.png
expect_error "render-frame: --lcm and files" 2 "'s3.tgrid': --lcm draws the peers' state" \
	render-frame --lcm file://x.lcmlog -o x.png s3.tgrid
expect_error "render-frame: --every without --lcm" 2 'go with --lcm' \
	render-frame --every 5 -o x.png s3.tgrid
expect_error "render-frame: --every 0" 2 '--every' render-frame --lcm default --every 0 -o x.png
