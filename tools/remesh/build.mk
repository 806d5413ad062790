TOOLS += remesh
remesh_SRCS := tools/remesh/main.c
