# lib/sim/build.mk — the physics layer's build settings.
#
# The implicit integrators (lib/sim/implicit.c) solve with CHOLMOD; the unit
# tests check the membrane's spectrum with LAPACK's dense eigensolver.
NDO_LIBS += -lcholmod -llapack -lblas
DEBS_TOOLS += libsuitesparse-dev liblapack-dev
# The stencil kernels (the acceleration, the explicit integrators) and the
# multigrid solver's loops: loops
# vectorized (-O3), reductions in them too (#pragma omp simd, no OpenMP
# runtime).
$(OBJ)/lib/sim/integrate.c.o $(OBJ)/lib/sim/rk4.c.o $(OBJ)/lib/sim/accel.c.o $(OBJ)/lib/sim/multigrid.c.o: CFLAGS += -O3 -fopenmp-simd
