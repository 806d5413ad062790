TOOLS += simulate-peer
simulate-peer_SRCS := tools/simulate-peer/main.c tools/simulate-peer/peers.c
# The implicit integrators (lib/implicit.c) solve with CHOLMOD; the unit
# tests check the membrane's spectrum with LAPACK's dense eigensolver.
NDO_LIBS += -lcholmod -llapack -lblas
DEBS_TOOLS += libsuitesparse-dev liblapack-dev libbullet-dev python3-matplotlib
# The stencil kernels: loops vectorized (-O3), reductions in them too
# (#pragma omp simd, no OpenMP runtime).
$(OBJ)/lib/integrate.c.o: CFLAGS += -O3 -fopenmp-simd

# Bullet's soft bodies, the reference the speed benchmark compares with
# (tests/bench/simulate.sh); linked only here, in double precision.
BULLET_CPPFLAGS := -DBT_USE_DOUBLE_PRECISION -isystem /usr/include/bullet
BULLET_LIBS := -lBulletSoftBody-float64 -lBulletDynamics-float64 \
               -lBulletCollision-float64 -lLinearMath-float64
$(TBIN)/bullet_softbody: tests/bench/bullet_softbody.cpp $(LIBNDO)
	@mkdir -p $(@D)
	$(CXX) $(CPPFLAGS) $(CXXFLAGS) -Wno-maybe-uninitialized $(BULLET_CPPFLAGS) $(LDFLAGS) -o $@ $< $(LIBNDO) \
	    $(BULLET_LIBS) $(NDO_LIBS)
bench: $(TBIN)/bullet_softbody
