# tests/e2e/netns.bash — sourced first by the scripts that run peers over LCM:
# the script runs again inside a private network namespace (unshare -n, as
# root), with the loopback up and multicast routed to it, so its traffic
# stays inside and parallel runs never hear each other (issue 6;
# tests/unit/netns.h does the same for the C tests).
if [ -z "${NDO_IN_NETNS:-}" ]; then
	NDO_IN_NETNS=1 exec unshare -n "$BASH" "$(realpath "$0")" "$@"
fi
if ! { ip link set lo up && ip route add 224.0.0.0/4 dev lo; } 2>/dev/null; then
	echo "FAIL $(basename "$0" .sh): no multicast route in the private network namespace"
	exit 1
fi
