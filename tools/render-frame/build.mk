TOOLS += render-frame
render-frame_SRCS := $(sort $(wildcard tools/render-frame/*.c))
# OpenGL itself is dlopen()ed at run time (context.c): libOSMesa.so.8 or
# libEGL.so.1; the -dev packages give the headers.
render-frame_LIBS := -lpng -lfreetype -lfontconfig -lpthread
tools/render-frame_CPPFLAGS := $(shell pkg-config --cflags freetype2 2>/dev/null || echo -I/usr/include/freetype2)
DEBS_TOOLS += libosmesa6-dev libegl-dev libgl-dev libpng-dev libfreetype-dev \
              libfontconfig-dev fonts-dejavu-core libosmesa6 libegl1 libegl-mesa0
