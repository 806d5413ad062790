/* shaders.h — where render-frame's GLSL sources are. */
#ifndef RF_SHADERS_H
#define RF_SHADERS_H

#include <stddef.h>

/* The directory holding the shaders, first of:
 *   $NDO_SHADER_DIR (when set, the only place looked at);
 *   BINDIR/../share/ndo/shaders (the installed layout, PREFIX/bin beside
 *   PREFIX/share);
 *   a shaders/ directory up to four levels above BINDIR (the source tree:
 *   bin/render-frame, build/asan/bin/render-frame),
 * where BINDIR holds the running binary.  A directory counts when it holds
 * `probe` (a shader file name).  NDO_ENOTFOUND with a detail naming the
 * places looked at when none does. */
int rf_shader_dir(const char *probe, char *out, size_t size);

#endif
