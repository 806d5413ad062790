/* machine.c — processors and memory (ndo/machine.h). */
#include "ndo/machine.h"

#include <sched.h>
#include <stdio.h>
#include <string.h>
#include <sys/resource.h>

int ndo_cpu_count(void)
{
	cpu_set_t set;
	if (sched_getaffinity(0, sizeof set, &set) == 0) {
		int n = CPU_COUNT(&set);
		if (n > 0)
			return n;
	}
	return 1;
}

size_t ndo_memory_available(void)
{
	size_t avail = 0;
	FILE *f = fopen("/proc/meminfo", "r");
	if (f) {
		char line[256];
		unsigned long long kb;
		while (fgets(line, sizeof line, f))
			if (sscanf(line, "MemAvailable: %llu kB", &kb) == 1) {
				avail = (size_t)kb * 1024;
				break;
			}
		fclose(f);
	}
	struct rlimit r;
	if (getrlimit(RLIMIT_AS, &r) == 0 && r.rlim_cur != RLIM_INFINITY &&
	    (avail == 0 || (size_t)r.rlim_cur < avail))
		avail = (size_t)r.rlim_cur;
	return avail;
}

const char *ndo_bytes_text(double bytes, char *buf, size_t size)
{
	static const char *const unit[] = {"bytes", "kB", "MB", "GB", "TB"};
	int u = 0;
	while (bytes >= 1000 && u < 4)
		bytes /= 1000, u++;
	snprintf(buf, size, u ? "%.3g %s" : "%.0f %s", bytes, unit[u]);
	return buf;
}
