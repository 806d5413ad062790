/* netns.h — run a test program in a private network namespace, so its LCM
 * multicast stays inside it: no other run (or engineer) hears it, and it
 * hears no one (issue 6: unshare -n, lo up, 224.0.0.0/4 routed to lo).
 * Call first in main(), before any thread exists: unshare(2) moves only
 * the calling thread, and the threads LCM starts later inherit it. */
#ifndef NDO_TEST_NETNS_H
#define NDO_TEST_NETNS_H

#include <sched.h>
#include <stdio.h>
#include <stdlib.h>

static int ck_private_netns(void)
{
	if (unshare(CLONE_NEWNET) != 0) {
		perror("unshare(CLONE_NEWNET) (needs root or CAP_SYS_ADMIN)");
		return -1;
	}
	if (system("ip link set lo up && ip route add 224.0.0.0/4 dev lo") != 0) {
		fprintf(stderr, "cannot set up loopback multicast in the namespace\n");
		return -1;
	}
	return 0;
}

#endif
