TOOLS += render-frame
render-frame_SRCS := $(sort $(wildcard tools/render-frame/*.c))
# OpenGL itself is dlopen()ed at run time (context.c): libOSMesa.so.8 or
# libEGL.so.1; the -dev packages give the headers.
render-frame_LIBS := -lpng -lfreetype -lfontconfig -lpthread
tools/render-frame_CPPFLAGS := $(shell pkg-config --cflags freetype2 2>/dev/null || echo -I/usr/include/freetype2)
# Headers: GL/osmesa.h, GL/glcorearb.h (libgl-dev), EGL/*.h; at run time
# Mesa's OSMesa, and EGL with the DRI software driver (llvmpipe).
# python3-pil: the tests read the PNGs.
DEBS_TOOLS += libosmesa6-dev libgl-dev libegl-dev libegl-mesa0 libgl1-mesa-dri libpng-dev \
              libfreetype-dev libfontconfig-dev fonts-dejavu-core python3-pil
