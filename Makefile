# imu-allan: the one entry point.  `make help` lists every target.
#   make deps      install the toolchain, Unity and the host package
#   make           build the firmware (MCU, F_CPU, BAUD may be overridden)
#   make test      every test
#   make demo      the main job, on a synthetic IMU
#   make clean
# A target documents itself: `name: prerequisites ## what it does` (a rule
# whose name is computed starts its text with `name: `), and make help
# prints it, file by file.

.DEFAULT_GOAL := all

MCU   ?= atmega168
F_CPU ?= 10000000
BAUD  ?= 115200
PYTHON ?= python3
BUILD ?= build
UNITY_DIR ?= $(CURDIR)/$(BUILD)/unity

AVR_CC   := avr-gcc
AVR_SIZE := avr-size
AVR_OBJCOPY := avr-objcopy

FW_DIR   := firmware
FW_BUILD := $(BUILD)/avr-$(MCU)
FW_SRC   := $(wildcard $(FW_DIR)/*.c)
FW_OBJ   := $(patsubst $(FW_DIR)/%.c,$(FW_BUILD)/%.o,$(FW_SRC))
ELF      := $(FW_BUILD)/imu-allan.elf
HEX      := $(FW_BUILD)/imu-allan.hex

# -mcall-prologues: register saves and restores through one shared routine
# instead of inline in every function: about 600 bytes of flash for a few
# cycles per call (the ISRs keep their own), which the ATmega168's 15,360
# bytes under a bootloader need (bench/run.py measures the cycles).
# -mrelax: calls and jumps within reach become rcall/rjmp (2 bytes each,
# and a cycle less).  -mstrict-X, -fno-move-loop-invariants: about 170
# bytes more; loop invariants are then recomputed in the loop (a few
# cycles in the engine's cascade: bench/run.py).  Together these keep
# the command line, its replies and the terminal conversation under the
# bootloader.
# -fno-inline-small-functions: with the terminal conversation, the noise
# terms and the summary the ATmega168 build was 15910 bytes, 38 over what
# optiboot's 512 bytes leave; this flag took 100 bytes off (make bench: no
# drops at any offered rate).
# -fno-tree-forwprop (for make bench's 15,360-byte flash target): about
# 130 bytes, most of them in the engine's accumulator reads; measured in
# imu-sim at 1 kHz, the engine's cycles per channel and the cycles per set
# do not get worse (they drop a little), the loop's idle passes cost a few
# cycles more (a 0.6 % larger busy fraction).  -fno-gcse would give 110
# bytes more but costs 2 bytes of the stack's 64-byte floor (the report's
# deepest path) and 5 % more CPU at 1 kHz: not used.
# --param max-inline-insns-single=1: what is declared inline (avr-libc's
# CRC steps, allan_waiting) is inlined only where always_inline says so:
# 22 bytes, with the engine's, the sampling loop's and the ISRs' code the
# same size (avr-nm, symbol by symbol), the CRC steps called as before.
FW_OPT := -Os -flto -mcall-prologues -mrelax -mstrict-X -fno-move-loop-invariants -fno-inline-small-functions \
          -fno-tree-forwprop --param max-inline-insns-single=1
# -fno-gcse also, but only for these modules: about 55 bytes for no cycles
# the loop spends (imu-sim at 1 kHz: the same busy fraction).  In the
# receiver and the ADC it is not used; in the engine and the sampling loop
# only as FW_MORE_allan and FW_MORE_sample below, where it was measured.
FW_COLD := stream proto reply command vocab link reset switchboard
$(foreach m,$(FW_COLD),$(eval $(FW_BUILD)/$(m).o: FW_CFLAGS += -fno-gcse))
# The modules that run between sets, never per sample (the report, the
# settings, the commands, the start-up in main): without these passes
# they are 132 bytes smaller (15650 -> 15518 when measured), toward make
# bench's 15,360-byte flash target.
# Each flag measured alone on them: -fno-tree-pre 30, -fno-tree-tail-merge
# 30, -fno-tree-sink 26, then -fno-tree-loop-ivcanon 56, -fno-tree-fre
# 12.  make bench measures what they cost in cycles and stack.
FW_SMALL := report settings control stream reply vocab reset main
FW_SMALL_FLAGS := -fno-gcse -fno-tree-pre -fno-tree-tail-merge -fno-tree-sink -fno-tree-loop-ivcanon -fno-tree-fre
$(foreach m,$(FW_SMALL),$(eval $(FW_BUILD)/$(m).o: FW_CFLAGS += $(FW_SMALL_FLAGS)))
# And for some of them one or two passes more, each measured on its own
# module (bytes saved alone: report -fno-ivopts 14, -fno-tree-dominator-opts
# 10; stream -fno-ivopts 18, -fno-expensive-optimizations 4; fmt
# -fno-tree-fre 8; control -fno-tree-coalesce-vars 4; main -fno-ivopts 4,
# -fno-expensive-optimizations 6; reply -fno-tree-ter 2; later report
# -fno-split-wide-types 62: its 32-bit values stay whole in registers,
# stack unchanged in imu-sim).
FW_MORE_report := -fno-ivopts -fno-tree-dominator-opts -fno-split-wide-types
FW_MORE_stream := -fno-ivopts -fno-expensive-optimizations
FW_MORE_fmt := -fno-tree-fre
FW_MORE_control := -fno-tree-coalesce-vars -fno-reorder-blocks
FW_MORE_main := -fno-ivopts -fno-expensive-optimizations
FW_MORE_reply := -fno-tree-ter
# Measured later, each on its module alone: console -fno-reorder-blocks 4,
# settings -fno-ivopts 4, switchboard -fno-tree-vrp 2.
FW_MORE_console := -fno-reorder-blocks
FW_MORE_settings := -fno-ivopts
FW_MORE_switchboard := -fno-tree-vrp
# In the engine and the sampling loop too, where imu-sim measured no
# slower sets (1 and 1.25 kHz: the worst set 3884 -> 3807 and 3897 ->
# 3803 cycles, the mean the same, the engine's mean per channel-sample
# 205.8 -> 204.1): allan -fno-tree-dominator-opts 68 bytes, -fno-gcse 18
# more; sample -fno-gcse 36.  sample -fira-algorithm=priority: the engine's
# code inlined into sample_take keeps its pointers in Y and Z (imu-sim, 1 kHz,
# 2^14 sets: 252.3 -> 247.3 engine cycles per channel-sample, 247.4 before
# the sample path was straightened), and 34 bytes.
FW_MORE_allan := -fno-tree-dominator-opts -fno-gcse
FW_MORE_sample := -fno-gcse -fira-algorithm=priority
$(foreach m,report stream fmt control main reply allan sample console switchboard settings command vocab proto units reset,$(eval $(FW_BUILD)/$(m).o: FW_CFLAGS += $(FW_MORE_$(m))))
FW_CFLAGS := -mmcu=$(MCU) -DF_CPU=$(F_CPU)UL -DBAUD=$(BAUD)UL \
             -std=gnu99 $(FW_OPT) -Wall -Wextra -Werror \
             -ffunction-sections -fdata-sections -MMD -MP
FW_LDFLAGS := -mmcu=$(MCU) $(FW_OPT) -Wl,--gc-sections -Wl,--section-start=.mmcu=0x910000

# One version for firmware and host: the VERSION file. The firmware gets it
# as FW_VERSION (boot line and report headers); `make version` writes the
# host package's copy (host_scripts/imu_allan/_version.py, checked by its tests).
VERSION := $(shell cat VERSION)
FW_CFLAGS += -DFW_VERSION='"$(VERSION)"'

# Extra compiler flags for experiments (e.g. FW_EXTRA=-flto), both steps.
FW_CFLAGS += $(FW_EXTRA)
FW_LDFLAGS += $(FW_EXTRA)

HOST_CC ?= cc
HOST_CFLAGS := -std=gnu99 -O2 -Wall -Wextra -Werror -I$(FW_DIR)

# The simulator harness imu-sim (defines IMU_SIM, used by rules below), and
# the fuzzers of the pure firmware modules (make fuzz, fuzz-smoke).
include sim/sim.mk
include tests/firmware/fuzz/fuzz.mk
# make flash / make fuses through avrdude (boards.mk explains the values).
include boards.mk

.PHONY: all help facts pyflakes lint format bench bench-long ext firmware other-mcus deps test firmware-test unit pytest sim-test system-test soak term-test flash-test demo demo-native clean version

all: firmware ## the firmware (the default goal): build/avr-MCU/imu-allan.hex

# One line per `## ` comment of a rule, in every makefile read (this one and
# the fragments it includes), grouped by file.
help: ## this list: every target, one line each
	@awk 'FNR == 1 { file = FILENAME } \
	  /^[^\t#=]+:[^=]*## / { \
	    text = $$0; sub(/^[^#]*## /, "", text); \
	    name = $$0; sub(/:.*/, "", name); \
	    if (name ~ /\$$/ && match(text, /^[^ :]+: /)) { \
	      name = substr(text, 1, RLENGTH - 2); text = substr(text, RLENGTH + 1) } \
	    if (file != shown) { printf "%s%s:\n", (shown == "" ? "" : "\n"), file; shown = file } \
	    printf "  %-22s %s\n", name, text }' $(MAKEFILE_LIST)

firmware: $(HEX) ## build the firmware ELF and hex for MCU at F_CPU and BAUD, and check it fits

# The Makefile too: FW_OPT goes into the objects (LTO).
$(FW_BUILD)/%.o: $(FW_DIR)/%.c VERSION Makefile | $(FW_BUILD)
	$(AVR_CC) $(FW_CFLAGS) -c $< -o $@

$(ELF): $(FW_OBJ)
	$(AVR_CC) $(FW_LDFLAGS) $^ -o $@
	$(AVR_SIZE) -C --mcu=$(MCU) $@

$(HEX): $(ELF)
	$(AVR_OBJCOPY) -O ihex -j .text -j .data $< $@

$(FW_BUILD):
	mkdir -p $@

-include $(FW_OBJ:.o=.d)

# The build's identity: every setting that goes into the firmware (MCU,
# F_CPU, BAUD, each -D and option of FW_CFLAGS and FW_LDFLAGS) is written to
# a stamp that every object depends on, rewritten only when it changes, so
# `make BAUD=9600` after `make` rebuilds instead of keeping the old ELF.
# firmware/build_id.c puts MCU, clock and baud into the ELF itself (section
# .imu_build, outside flash), which `make flash` checks (boards.mk).  Kept out
# of LTO so that the linker keeps the section.
FW_STAMP := $(FW_BUILD)/build-settings
FW_IDENTITY := MCU=$(MCU) F_CPU=$(F_CPU) BAUD=$(BAUD) | $(FW_CFLAGS) | $(FW_LDFLAGS)
ifneq ($(file <$(FW_STAMP)),$(FW_IDENTITY))
  $(shell mkdir -p $(FW_BUILD))
  $(file >$(FW_STAMP),$(FW_IDENTITY))
endif
$(FW_OBJ): $(FW_STAMP)
$(FW_BUILD)/build_id.o: FW_CFLAGS += -fno-lto
FW_LDFLAGS += -Wl,--undefined=build_id -Wl,--section-start=.imu_build=0x920000

version: ## write the host package's _version.py from VERSION
	printf '%s\n' '# Generated from the repository'"'"'s VERSION file by `make version` (the Makefile' \
	  '# also passes it to the firmware as FW_VERSION); tests/test_version.py checks' \
	  '# that the two agree. Edit VERSION, not this file.' \
	  '__version__ = "$(VERSION)"' > host_scripts/imu_allan/_version.py

# The facts the host shares with the firmware (rates, code range, column
# order, the protocol's words), read from firmware/ into the host package,
# which then works installed on its own; its tests fail when the two part.
FACTS_PY := host_scripts/imu_allan/_firmware_facts.py

facts: ## write the host package's _firmware_facts.py from the firmware's headers and tables
	$(PYTHON) scripts/firmware_facts.py -o $(FACTS_PY)

deps: ## install the toolchain, Unity, clang-format and the host package with its test extras
	BUILD=$(CURDIR)/$(BUILD) PYTHON=$(PYTHON) bash scripts/deps.sh
	$(MAKE) --no-print-directory ext

# The compiled Allan kernels (host_scripts/imu_allan/stats/_ckernels.c) built in
# place beside kernels.py, as `pip install` builds them; rebuilt when the source
# changes. Optional: without a C compiler the host package uses its numpy path.
ext: ## build the host package's compiled Allan kernels in place
	cd host_scripts && $(PYTHON) setup.py -q build_ext --inplace --build-temp $(CURDIR)/$(BUILD)/ext

# ---- tests ---------------------------------------------------------------
test: lint firmware other-mcus firmware-test pytest system-test ## every test (8+ minutes)
	$(MAKE) --no-print-directory -j 2 --output-sync=target fuzz-smoke

# The three system test sets side by side.  sim-test keeps both cores busy
# (pytest -n 2, each worker running imu-sim flat out); term-test and
# flash-test mostly wait on devices simulated in real time (imu-sim --pty
# uses about a tenth of a core), so they run beside it, one after the other,
# and sim-test runs niced: a busy core never makes their devices fall behind
# the wall clock.  Each set's output is shown whole when it ends.
system-test: firmware $(IMU_SIM) bootloader ## sim-test beside term-test then flash-test (part of make test)
	$(MAKE) --no-print-directory -j 2 --output-sync=target SIM_NICE="nice -n 10" sim-test term-test flash-test

# The ATmega328P build must keep compiling (20 octaves, 48-bit accumulators).
other-mcus: ## the ATmega328P build (20 octaves, 48-bit accumulators) still compiles
	$(MAKE) --no-print-directory firmware MCU=atmega328p

firmware-test unit: ## the firmware's Unity and native tests (cmake, ctest); unit: its former name
	cmake -S tests/firmware/unit -B $(BUILD)/firmware-test -DUNITY_DIR=$(UNITY_DIR) >/dev/null
	cmake --build $(BUILD)/firmware-test -j 2
	cd $(BUILD)/firmware-test && ctest --output-on-failure -j 2

# The host tests that drive the real firmware in imu-sim (sweep, the report
# check line) need both built; without them they would skip.
pytest: firmware $(IMU_SIM) ext ## the host package's tests (host_scripts/tests)
	cd host_scripts && $(PYTHON) -m pytest -q -n 2

# The simulated device on a pseudo-terminal, driven as a user would.
term-test: firmware $(IMU_SIM) ## the simulated device on a pseudo-terminal, driven as a user would
	BUILD=$(CURDIR)/$(BUILD) PYTHONPATH=$(CURDIR)/host_scripts $(PYTHON) -m pytest -q tests/system/term

# make flash with the real avrdude against the real optiboot on the simulated
# board (make sim-board), and the reset causes with and without it.
flash-test: firmware $(IMU_SIM) bootloader ## make flash with avrdude and optiboot on the simulated board
	BUILD=$(CURDIR)/$(BUILD) $(PYTHON) -m pytest -q -p no:cacheprovider tests/system/flash

# The real firmware ELF in simavr on synthetic streams, each checked exactly.
# SIM_NICE: a command in front of it (system-test's `nice -n 10`).
SIM_NICE ?=
sim-test: firmware $(IMU_SIM) ## the firmware ELF in simavr on synthetic streams, checked exactly
	BUILD=$(CURDIR)/$(BUILD) PYTHONPATH=$(CURDIR)/host_scripts $(SIM_NICE) $(PYTHON) -m pytest -q -n 2 tests/system/sim

# ---- lint and format -------------------------------------------------------
# Python: ruff (ruff.toml: check and format); C: clang-format (.clang-format,
# refined in sim/ and the host's C kernels); mypy on the host package's public
# API (host_scripts/pyproject.toml).  `make lint` reports every finding of the
# four and fails if any; `make format` applies ruff's safe fixes, its
# formatter and clang-format in place.
CLANG_FORMAT ?= clang-format
C_SOURCES = $(shell git ls-files -- '*.c' '*.h' 2>/dev/null || find firmware sim tests tools host_scripts -name build -prune -o -name '*.[ch]' -print)

# The errors among the lint findings (undefined names, unused imports and
# variables, redefinitions: ruff's pyflakes rules), in every `make test` until
# the format pass lets `make lint` itself join it: an undefined name in a
# code path no test reaches is otherwise found only by a user.
pyflakes: ## ruff's pyflakes rules (undefined names, unused imports) on every Python file
	$(PYTHON) -m ruff check --select F --output-format=concise .

lint: ## ruff check and ruff format --check (Python), clang-format (C), mypy (host public API)
	@rc=0; \
	echo "ruff check"; $(PYTHON) -m ruff check --output-format=concise . || rc=1; \
	echo "ruff format --check"; $(PYTHON) -m ruff format --check . || rc=1; \
	echo "clang-format --dry-run"; $(CLANG_FORMAT) --dry-run -Werror $(C_SOURCES) || rc=1; \
	echo "mypy (host_scripts/pyproject.toml)"; (cd host_scripts && $(PYTHON) -m mypy) || rc=1; \
	exit $$rc

format: ## apply ruff's safe fixes, ruff format and clang-format to every Python and C file
	$(PYTHON) -m ruff check --fix --quiet . || true
	$(PYTHON) -m ruff format .
	$(CLANG_FORMAT) -i $(C_SOURCES)

# ---- benchmark --------------------------------------------------------------
# The link soak: 1,000 runs of random back-to-back commands over a link that
# loses and flips bytes at 1e-3 each way (tests/system/sim/soak.py says what is
# counted); `make sim-test` runs a sample of 12.  SOAK_RUNS=N for another count.
SOAK_RUNS ?= 1000
soak: firmware $(IMU_SIM) ## the link soak: 1,000 runs of random commands over a lossy, bit-flipping link
	BUILD=$(CURDIR)/$(BUILD) PYTHONPATH=$(CURDIR)/host_scripts $(PYTHON) tests/system/sim/soak.py --runs $(SOAK_RUNS)

# Device, simulator and host side by side; writes bench/results.json.
# Then the long recording (bench/long.py): 8 h at 1 kHz of TSV (generated once
# into build/bench/) through `imu-allan analyze` beside allantools' oadev, and
# a ROS 2 bag of the same 8 h against it (~10 GB, written once into build/bench/).
# BENCH_QUICK=1: a sixteenth of each; BENCH_ROWS=N, BENCH_BAG_ROWS=N (0: no bag) for other sizes.
BENCH_ROWS ?= $(if $(BENCH_QUICK),1800000,28800000)
BENCH_BAG_ROWS ?= $(BENCH_ROWS)
bench: firmware $(IMU_SIM) ext ## device, simulator and host figures side by side into bench/results.json
	BUILD=$(CURDIR)/$(BUILD) $(PYTHON) bench/run.py $(BENCH_ARGS) $(if $(BENCH_QUICK),--quick)
	$(MAKE) --no-print-directory bench-long

bench-long: ext ## only the long recording's figures (BENCH_QUICK=1, BENCH_ROWS=N, BENCH_BAG_ROWS=N)
	BUILD=$(CURDIR)/$(BUILD) $(PYTHON) bench/long.py --rows $(BENCH_ROWS) --bag-rows $(BENCH_BAG_ROWS)

# ---- demo ------------------------------------------------------------------
# The main job: 10 minutes of a synthetic thesis-like IMU at 100 Hz through
# the simulated device, then the device's results as a user reads them.
DEMO_DIR := $(BUILD)/demo
# This checkout's own package, whatever another checkout installed.
IMU_ALLAN := PYTHONPATH=$(CURDIR)/host_scripts $(PYTHON) -m imu_allan.cli

demo: firmware $(IMU_SIM) ## 10 minutes of a synthetic IMU through the simulated device; ends with its summary and the check
	@mkdir -p $(DEMO_DIR)
	@$(IMU_ALLAN) gen -n 60000 --fs 100 --seed 1 -o $(DEMO_DIR)/imu.tsv
	@echo "== simulated device: 60000 samples (10 min at 100 Hz) =="
	@$(IMU_ALLAN) sim --adc $(DEMO_DIR)/imu.tsv --fs 100 -o $(DEMO_DIR)/device.log \
	  --stats $(DEMO_DIR)/stats.json
	@$(PYTHON) -c 'import json,sys; s=json.load(open(sys.argv[1])); \
	  print("simulated %.0f s in %.1f s of wall time (%.0fx), stack free %d bytes" % \
	  (s["sim_seconds"], s["wall_seconds"], s["sim_speed_x"], s["stack_free_bytes"]))' $(DEMO_DIR)/stats.json
	@$(IMU_ALLAN) decode $(DEMO_DIR)/device.log > $(DEMO_DIR)/decoded.txt
	@echo "written: the decoded table (imu-allan decode; avar in code^2, adev in code)"
	@echo "and the check's details: $(DEMO_DIR)/decoded.txt $(DEMO_DIR)/check.txt"
	@echo "== the device's own summary of its last report, as a terminal shows it =="
	@$(IMU_ALLAN) check $(DEMO_DIR)/device.log $(DEMO_DIR)/imu.tsv > $(DEMO_DIR)/check.txt; rc=$$?; \
	  grep '^\$$S' $(DEMO_DIR)/device.log | tail -n 22 | sed -e 's/^\$$S,[0-9]*,//' -e 's/\*[0-9A-F]*.$$//'; \
	  echo "check: $$(tail -n 1 $(DEMO_DIR)/check.txt)"; \
	  exit $$rc

# The engine alone, natively, on 2^20 synthetic samples.
NATIVE_DEMO := $(BUILD)/host/allan-demo

$(NATIVE_DEMO): tools/allan_demo.c $(FW_DIR)/allan.c $(FW_DIR)/allan.h $(FW_DIR)/config.h
	mkdir -p $(dir $@)
	$(HOST_CC) $(HOST_CFLAGS) tools/allan_demo.c $(FW_DIR)/allan.c -lm -o $@

demo-native: $(NATIVE_DEMO) ## the Allan engine alone, natively, on 2^20 synthetic samples
	$(NATIVE_DEMO)

clean: ## remove the firmware, firmware-test and native builds (build/avr-*, firmware-test, host)
	rm -rf $(BUILD)/avr-* $(BUILD)/unit $(BUILD)/firmware-test $(BUILD)/host
