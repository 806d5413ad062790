TOOLS += simulate-peer
simulate-peer_SRCS := tools/simulate-peer/main.c
# The implicit integrators (lib/implicit.c) solve with CHOLMOD; the unit
# tests check the membrane's spectrum with LAPACK's dense eigensolver.
NDO_LIBS += -lcholmod -llapack -lblas
DEBS_TOOLS += libsuitesparse-dev liblapack-dev libbullet-dev python3-matplotlib
# The stencil kernels: loops vectorized (-O3), reductions in them too
# (#pragma omp simd, no OpenMP runtime).
$(OBJ)/lib/integrate.c.o: CFLAGS += -O3 -fopenmp-simd
