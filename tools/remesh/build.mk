TOOLS += remesh
remesh_SRCS := tools/remesh/main.cpp tools/remesh/load.cpp tools/remesh/param.cpp \
               tools/remesh/resample.cpp tools/remesh/rotation.cpp tools/remesh/quality.cpp \
               tools/remesh/progress.cpp
remesh_LIBS := -lgmp -lmpfr -fopenmp
DEBS_TOOLS += libcgal-dev libeigen3-dev libgmp-dev libmpfr-dev libcgal-demo
# CGAL's headers: no assertions in the hot loops of the optimized build
# (they stay on in the sanitizer build), and no warnings from its headers.
tools/remesh_CPPFLAGS := -fopenmp -isystem /usr/include/eigen3 $(if $(filter 1,$(SAN)),,-DCGAL_NDEBUG)
