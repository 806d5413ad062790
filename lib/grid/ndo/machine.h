/* ndo/machine.h — what the machine offers a run: processors and memory. */
#ifndef NDO_MACHINE_H
#define NDO_MACHINE_H

#include <stddef.h>

/* The processors this process may run on (sched_getaffinity), at least 1. */
int ndo_cpu_count(void);

/* The bytes a new allocation can take without swapping: the kernel's
 * MemAvailable (/proc/meminfo), or the address-space limit (ulimit -v)
 * when that is lower; 0 when neither can be read. */
size_t ndo_memory_available(void);

/* "1.5 GB", "320 MB", "12 kB": bytes for a person (buf ≥ 16 bytes). */
const char *ndo_bytes_text(double bytes, char *buf, size_t size);

#endif
