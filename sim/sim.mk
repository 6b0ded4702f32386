# sim/sim.mk - imu-sim, the simavr harness that runs the firmware ELF on
# ADC rows, and the simavr section of the firmware ELF (included by the
# top-level Makefile: BUILD, HOST_CC, ELF, FW_* and AVR_CC come from it).
#   make sim          build $(BUILD)/host/imu-sim
#   make sim-term     the simulated device on a pseudo-terminal, for a
#                     serial terminal or the host tools (Ctrl-C ends it)
# Other rules may depend on $(IMU_SIM).

# This fragment must not change the default goal of the including Makefile
# (`make` alone builds the firmware): remember it, restored at the end.
SIM_MK_DEFAULT_GOAL := $(.DEFAULT_GOAL)

# simavr's .mmcu section (sim/simavr_section.c), linked into the firmware
# ELF when simavr's header is installed: the harness reads the MCU and
# clock from it; the section is not flashed.
ifneq ($(wildcard /usr/include/simavr/avr/avr_mcu_section.h),)
FW_CFLAGS += -idirafter /usr/include/simavr -DHAVE_SIMAVR_SECTION
FW_LDFLAGS += -Wl,--undefined=_mmcu
endif
FW_OBJ += $(FW_BUILD)/simavr_section.o

# Without LTO: its link-time optimizer drops the name and clock records,
# which nothing references, and simavr would find only the end tag (and
# take any ELF for an ATmega168 at its default clock).
$(FW_BUILD)/simavr_section.o: sim/simavr_section.c sim/sim.mk | $(FW_BUILD)
	$(AVR_CC) $(FW_CFLAGS) -fno-lto -I$(FW_DIR) -c $< -o $@

IMU_SIM := $(BUILD)/host/imu-sim
# The harness's rooms (harness.h lists them), and the firmware's own CRC.
IMU_SIM_SRC := $(addprefix sim/,imu_sim.c sim_cli.c sim_msg.c sim_serial.c \
               sim_drive.c sim_adc.c sim_measure.c sim_termrun.c sim_board.c sim_fault.c sim_rows.c \
               sim_term.c sim_err.c sim_isr.c) $(FW_DIR)/crc.c
IMU_SIM_HDR := $(addprefix sim/,harness.h sim_msg.h sim_serial.h sim_drive.h sim_adc.h sim_measure.h sim_board.h sim_termrun.h sim_cli.h sim_fault.h sim_rows.h sim_term.h sim_err.h sim_isr.h) \
               $(FW_DIR)/crc.h

# simavr's headers include each other as "sim_avr.h", so their directory
# goes on the include path; as -isystem, so that -Werror spares them.
SIMAVR_CFLAGS := $(patsubst -I%,-isystem %,$(shell pkg-config --cflags simavr 2>/dev/null))
ifeq ($(strip $(SIMAVR_CFLAGS)),)
SIMAVR_CFLAGS := -isystem /usr/include/simavr
endif
# libsimavr itself only needs libelf; imu-sim reads the ELF's symbols with
# libelf too, and the synthetic IMU needs libm.
IMU_SIM_CFLAGS := -std=gnu99 -O2 -Wall -Wextra -Werror -I$(FW_DIR) $(SIMAVR_CFLAGS)
IMU_SIM_LIBS := -lsimavr -lelf -lm

# sim-term: where the terminal link goes, and extra imu-sim options
# (e.g. SIM_TERM_OPTS=--fast, or "--adc capture.tsv" instead of --synthetic).
SIM_TERM_LINK ?= $(BUILD)/imu-tty
SIM_TERM_OPTS ?= --synthetic

.PHONY: sim sim-term

sim: $(IMU_SIM) ## build imu-sim, the simavr harness that runs the firmware ELF

$(IMU_SIM): $(IMU_SIM_SRC) $(IMU_SIM_HDR) sim/sim.mk
	mkdir -p $(dir $@)
	$(HOST_CC) $(IMU_SIM_CFLAGS) $(IMU_SIM_SRC) $(IMU_SIM_LIBS) -o $@

sim-term: firmware $(IMU_SIM) ## the simulated device on a pseudo-terminal (build/imu-tty) for a terminal or the host
	@echo "sim-term: the simulated device is on $(SIM_TERM_LINK) (Ctrl-C here ends it); in another shell:"
	@echo "    picocom -b $(BAUD) $(SIM_TERM_LINK)     (Ctrl-A Ctrl-X quits picocom)"
	@echo "    imu-allan monitor --port $(SIM_TERM_LINK)"
	@echo "    python3 -m serial.tools.miniterm $(SIM_TERM_LINK) $(BAUD)"
	@echo "It powers up when the terminal opens it; simulated time runs in real time."
	$(IMU_SIM) --pty --link $(SIM_TERM_LINK) $(SIM_TERM_OPTS) $(ELF)

.DEFAULT_GOAL := $(SIM_MK_DEFAULT_GOAL)
