TOOLS += subdivide
subdivide_SRCS := tools/subdivide/main.c
