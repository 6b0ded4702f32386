# sim/sim.mk - imu-sim, the simavr harness that runs the firmware ELF on
# ADC rows (included by the top-level Makefile: BUILD, HOST_CC come from it).
#   make sim          build $(BUILD)/host/imu-sim
# Other rules may depend on $(IMU_SIM).

IMU_SIM := $(BUILD)/host/imu-sim
IMU_SIM_SRC := sim/imu_sim.c sim/sim_rows.c
IMU_SIM_HDR := sim/sim_rows.h

# simavr's headers include each other as "sim_avr.h", so their directory
# goes on the include path; as -isystem, so that -Werror spares them.
SIMAVR_CFLAGS := $(patsubst -I%,-isystem %,$(shell pkg-config --cflags simavr 2>/dev/null))
ifeq ($(strip $(SIMAVR_CFLAGS)),)
SIMAVR_CFLAGS := -isystem /usr/include/simavr
endif
# libsimavr itself only needs libelf; imu-sim reads the ELF's symbols with
# libelf too.
IMU_SIM_CFLAGS := -std=gnu99 -O2 -Wall -Wextra -Werror $(SIMAVR_CFLAGS)
IMU_SIM_LIBS := -lsimavr -lelf

.PHONY: sim

sim: $(IMU_SIM)

$(IMU_SIM): $(IMU_SIM_SRC) $(IMU_SIM_HDR) sim/sim.mk
	mkdir -p $(dir $@)
	$(HOST_CC) $(IMU_SIM_CFLAGS) $(IMU_SIM_SRC) $(IMU_SIM_LIBS) -o $@
