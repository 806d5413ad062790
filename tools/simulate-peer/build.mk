TOOLS += simulate-peer
simulate-peer_SRCS := tools/simulate-peer/main.c tools/simulate-peer/run.c \
                      tools/simulate-peer/peers.c tools/simulate-peer/accuracy.c
DEBS_TOOLS += libbullet-dev python3-matplotlib

# Bullet's soft bodies, the reference the speed benchmark compares with
# (tests/bench/simulate.sh); linked only here, in double precision.
BULLET_CPPFLAGS := -DBT_USE_DOUBLE_PRECISION -isystem /usr/include/bullet
BULLET_LIBS := -lBulletSoftBody-float64 -lBulletDynamics-float64 \
               -lBulletCollision-float64 -lLinearMath-float64
$(TBIN)/bullet_softbody: tests/bench/bullet_softbody.cpp $(LIBNDO)
	@mkdir -p $(@D)
	$(CXX) $(CPPFLAGS) $(ALL_INC) -I$(LCM_GEN_DIR) $(CXXFLAGS) -Wno-maybe-uninitialized $(BULLET_CPPFLAGS) $(LDFLAGS) -o $@ $< $(LIBNDO) \
	    $(BULLET_LIBS) $(NDO_LIBS)
bench: $(TBIN)/bullet_softbody
