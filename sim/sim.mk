# sim/sim.mk - imu-sim, the simavr harness that runs the firmware ELF on
# ADC rows (included by the top-level Makefile: BUILD, HOST_CC, ELF come
# from it).
#   make sim          build $(BUILD)/host/imu-sim
#   make sim-term     the simulated device on a pseudo-terminal, for a
#                     serial terminal or the host tools (Ctrl-C ends it)
# Other rules may depend on $(IMU_SIM).

# This fragment must not change the default goal of the including Makefile
# (`make` alone builds the firmware): remember it, restored at the end.
SIM_MK_DEFAULT_GOAL := $(.DEFAULT_GOAL)

IMU_SIM := $(BUILD)/host/imu-sim
IMU_SIM_SRC := sim/imu_sim.c sim/sim_rows.c sim/sim_term.c sim/sim_isr.c
IMU_SIM_HDR := sim/sim_rows.h sim/sim_term.h sim/sim_isr.h

# simavr's headers include each other as "sim_avr.h", so their directory
# goes on the include path; as -isystem, so that -Werror spares them.
SIMAVR_CFLAGS := $(patsubst -I%,-isystem %,$(shell pkg-config --cflags simavr 2>/dev/null))
ifeq ($(strip $(SIMAVR_CFLAGS)),)
SIMAVR_CFLAGS := -isystem /usr/include/simavr
endif
# libsimavr itself only needs libelf; imu-sim reads the ELF's symbols with
# libelf too, and the synthetic IMU needs libm.
IMU_SIM_CFLAGS := -std=gnu99 -O2 -Wall -Wextra -Werror $(SIMAVR_CFLAGS)
IMU_SIM_LIBS := -lsimavr -lelf -lm

# sim-term: where the terminal link goes, and extra imu-sim options
# (e.g. SIM_TERM_OPTS=--fast, or "--adc capture.tsv" instead of --synthetic).
SIM_TERM_LINK ?= $(BUILD)/imu-tty
SIM_TERM_OPTS ?= --synthetic

.PHONY: sim sim-term

sim: $(IMU_SIM)

$(IMU_SIM): $(IMU_SIM_SRC) $(IMU_SIM_HDR) sim/sim.mk
	mkdir -p $(dir $@)
	$(HOST_CC) $(IMU_SIM_CFLAGS) $(IMU_SIM_SRC) $(IMU_SIM_LIBS) -o $@

sim-term: firmware $(IMU_SIM)
	@echo "sim-term: the simulated device is on $(SIM_TERM_LINK) (Ctrl-C here ends it); in another shell:"
	@echo "    picocom -b $(BAUD) $(SIM_TERM_LINK)     (Ctrl-A Ctrl-X quits picocom)"
	@echo "    imu-allan monitor --port $(SIM_TERM_LINK)"
	@echo "    python3 -m serial.tools.miniterm $(SIM_TERM_LINK) $(BAUD)"
	@echo "It powers up when the terminal opens it; simulated time runs in real time."
	$(IMU_SIM) --pty --link $(SIM_TERM_LINK) $(SIM_TERM_OPTS) $(ELF)

.DEFAULT_GOAL := $(SIM_MK_DEFAULT_GOAL)
