/* shaders.c — find the shader directory (shaders.h). */
#include "shaders.h"

#include "ndo/status.h"

#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static int holds(const char *dir, const char *probe)
{
	char path[PATH_MAX];
	int n = snprintf(path, sizeof path, "%s/%s", dir, probe);
	return n > 0 && (size_t)n < sizeof path && access(path, R_OK) == 0;
}

int rf_shader_dir(const char *probe, char *out, size_t size)
{
	const char *env = getenv("NDO_SHADER_DIR");
	if (env && *env) {
		if (!holds(env, probe))
			return ndo__fail(NDO_ENOTFOUND, "shader %s/%s: not found (NDO_SHADER_DIR)", env,
			                 probe);
		snprintf(out, size, "%s", env);
		return NDO_OK;
	}
	char exe[PATH_MAX];
	ssize_t n = readlink("/proc/self/exe", exe, sizeof exe - 1);
	if (n <= 0)
		return ndo__fail(NDO_ENOTFOUND, "cannot tell where the binary is; set NDO_SHADER_DIR");
	exe[n] = '\0';
	char *slash = strrchr(exe, '/');
	if (slash)
		*slash = '\0'; /* BINDIR */
	char dir[PATH_MAX + 64];
	snprintf(dir, sizeof dir, "%s/../share/ndo/shaders", exe);
	if (holds(dir, probe))
		return snprintf(out, size, "%s", dir), NDO_OK;
	char up[PATH_MAX + 64] = "";
	for (int k = 1; k <= 4; k++) {
		strcat(up, "../");
		snprintf(dir, sizeof dir, "%s/%sshaders", exe, up);
		if (holds(dir, probe))
			return snprintf(out, size, "%s", dir), NDO_OK;
	}
	return ndo__fail(NDO_ENOTFOUND, "shader %s: not found in %s/../share/ndo/shaders nor in a "
	                 "shaders/ directory above %s; set NDO_SHADER_DIR", probe, exe, exe);
}
