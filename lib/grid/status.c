/* status.c — status codes and the per-thread error detail (ndo/status.h). */
#include "ndo/status.h"

#include <stdarg.h>
#include <stdio.h>
#include <string.h>

static _Thread_local char detail[512];
static _Thread_local int detail_code;

const char *ndo_strerror(int code)
{
	switch (code) {
	case NDO_OK: return "success";
	case NDO_ENOMEM: return "out of memory";
	case NDO_EIO: return "input/output error";
	case NDO_ETRUNC: return "truncated input";
	case NDO_EFORMAT: return "malformed input";
	case NDO_ECORRUPT: return "checksum mismatch";
	case NDO_EVERSION: return "unsupported format version";
	case NDO_ERANGE: return "value out of range";
	case NDO_EINVAL: return "invalid argument";
	case NDO_ENOTFOUND: return "not found";
	case NDO_EEXPORT: return "mesh export failed";
	case NDO_EEOF: return "end of input";
	case NDO_EDIVERGED: return "simulation diverged";
	case NDO_EPACE: return "cannot keep the pace";
	}
	return "unknown error";
}

int ndo__fail(int code, const char *fmt, ...)
{
	/* Format into a copy first: a caller may pass ndo_errdetail() itself
	 * as an argument ("%s: %s", path, ndo_errdetail()) to add context. */
	char buf[sizeof detail];
	va_list ap;
	va_start(ap, fmt);
	vsnprintf(buf, sizeof buf, fmt, ap);
	va_end(ap);
	memcpy(detail, buf, sizeof detail);
	detail_code = code;
	return code;
}

void ndo__clear_error(void)
{
	detail[0] = '\0';
	detail_code = 0;
}

const char *ndo_errdetail(void)
{
	if (detail[0] == '\0')
		return ndo_strerror(detail_code);
	return detail;
}
