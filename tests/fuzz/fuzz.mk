# tests/fuzz/fuzz.mk - libFuzzer targets for the firmware's pure modules,
# built natively with clang (Debian's clang-14 + libclang-rt-14-dev) under
# AddressSanitizer and UndefinedBehaviorSanitizer, any finding fatal.
#
#   make fuzz [FUZZ_SECONDS=N]   build all targets into $(BUILD)/fuzz/ and run
#                                each N seconds (default 10); fails on any
#                                crash, sanitizer report, failed check or hang
#   make fuzz-smoke              the short run of `make test` (3 s a target)
#   make fuzz-clean              remove $(BUILD)/fuzz
#
# Targets (tests/fuzz/<target>.c; seeds in tests/fuzz/corpus/<target>/):
#   fuzz_command   command_parse() on arbitrary lines, up to FUZZ_COMMAND_MAX_LEN
#                  bytes: result codes, blank lines, case, blanks, determinism
#   fuzz_proto     proto_* framing, crc16, fmt_u32/fmt_hex vs an independent
#                  decoder, CRC and snprintf; corrupted lines never accepted
#   fuzz_fmt       fmt_adev/fmt_tau/fmt_sig3: 3 significant digits vs double
#   fuzz_allan     the Allan engine vs an exact 128-bit reference, after every
#                  push (default build: 15 levels, 48-bit from level 11)
#   fuzz_allan20   the same with -DALLAN_LEVELS=20 -DALLAN_ACC48_FROM=0
# Each run works on a copy of the seeds in $(BUILD)/fuzz/corpus-<target>,
# which keeps what it found for the next `make fuzz` (fuzz-smoke starts
# from the seeds alone each time, in smoke-corpus-<target>); the repo's
# corpus is never written.  A failure prints the log's tail and leaves the
# input as $(BUILD)/fuzz/<target>-crash-* (or -timeout-*, -oom-*); replay it
# with `$(BUILD)/fuzz/<target> FILE`.
#
# Included by the top-level Makefile (which defines BUILD and FW_DIR); on its
# own: make -f tests/fuzz/fuzz.mk fuzz

# Keep the including Makefile's default goal.
FUZZ_SAVED_GOAL := $(.DEFAULT_GOAL)

BUILD ?= build
FW_DIR ?= firmware
FUZZ_SECONDS ?= 10
FUZZ_SMOKE_SECONDS ?= 3
# Seconds one input may take before it counts as a hang.
FUZZ_TIMEOUT ?= 20
# More libFuzzer flags, e.g. -seed=1 or -jobs=4.
FUZZ_FLAGS ?=
# Lines of 256 bytes and more make command_parse() loop forever (its 8-bit
# word length wraps); the device never passes more than COMMAND_LINE_MAX.
# Raise this past 256 once that is fixed.
FUZZ_COMMAND_MAX_LEN ?= 300

FUZZ_CC ?= $(shell command -v clang-14 || command -v clang)
FUZZ_DIR := tests/fuzz
FUZZ_OUT := $(BUILD)/fuzz
FUZZ_CFLAGS := -std=gnu99 -g -O1 -fsanitize=fuzzer,address,undefined -fno-sanitize-recover=all \
               -Wall -Wextra -Werror -I $(FW_DIR) -I $(FUZZ_DIR)
FUZZ_DEPS := $(wildcard $(FW_DIR)/*.h) $(FUZZ_DIR)/fuzz_util.h $(FUZZ_DIR)/fuzz.mk

FUZZ_TARGETS := fuzz_command fuzz_cmdline fuzz_proto fuzz_fmt fuzz_allan fuzz_allan20

# Per target: firmware sources, extra flags, seed directory, input size.
FUZZ_SRC_fuzz_command := command.c vocab.c
# The receiver with the parser, on whole byte streams (NULs and all bytes).
FUZZ_SRC_fuzz_cmdline := console.c command.c vocab.c proto.c crc.c fmt.c
FUZZ_SRC_fuzz_proto := proto.c crc.c fmt.c
FUZZ_SRC_fuzz_fmt := fmt.c
FUZZ_SRC_fuzz_allan := allan.c
FUZZ_SRC_fuzz_allan20 := allan.c
# The engine target runs 2^16+ pushes an input: comparison tracing (the
# fuzzer's value profile) would halve its speed for little gain.
FUZZ_XFLAGS_fuzz_cmdline := -DF_CPU=10000000UL
FUZZ_XFLAGS_fuzz_allan := -fno-sanitize-coverage=trace-cmp
FUZZ_XFLAGS_fuzz_allan20 := -fno-sanitize-coverage=trace-cmp -DALLAN_LEVELS=20 -DALLAN_ACC48_FROM=0
FUZZ_MAIN_fuzz_allan20 := fuzz_allan
FUZZ_SEEDS_fuzz_allan20 := fuzz_allan
FUZZ_MAX_LEN_fuzz_command = $(FUZZ_COMMAND_MAX_LEN)
FUZZ_MAX_LEN_fuzz_cmdline := 512
FUZZ_MAX_LEN_fuzz_proto := 1024
FUZZ_MAX_LEN_fuzz_fmt := 32
FUZZ_MAX_LEN_fuzz_allan := 2048
FUZZ_MAX_LEN_fuzz_allan20 := 2048

fuzz_main = $(FUZZ_DIR)/$(or $(FUZZ_MAIN_$(1)),$(1)).c
fuzz_seeds = $(FUZZ_DIR)/corpus/$(or $(FUZZ_SEEDS_$(1)),$(1))

FUZZ_BINS := $(addprefix $(FUZZ_OUT)/,$(FUZZ_TARGETS))
FUZZ_RUNS := $(addprefix fuzz-run-,$(FUZZ_TARGETS))
FUZZ_SMOKES := $(addprefix fuzz-smoke-,$(FUZZ_TARGETS))

.PHONY: fuzz fuzz-smoke fuzz-build fuzz-clean $(FUZZ_RUNS) $(FUZZ_SMOKES)

fuzz: $(FUZZ_RUNS)
fuzz-smoke: $(FUZZ_SMOKES)
fuzz-build: $(FUZZ_BINS)

define fuzz_bin_rule
$(FUZZ_OUT)/$(1): $(call fuzz_main,$(1)) $(addprefix $(FW_DIR)/,$(FUZZ_SRC_$(1))) $(FUZZ_DEPS)
	@test -n "$(FUZZ_CC)" || { echo "fuzz: no clang-14 or clang (apt-get install clang-14 libclang-rt-14-dev)"; exit 1; }
	@mkdir -p $(FUZZ_OUT)
	$(FUZZ_CC) $(FUZZ_CFLAGS) $(FUZZ_XFLAGS_$(1)) $$(filter %.c,$$^) -lm -o $$@
endef
$(foreach t,$(FUZZ_TARGETS),$(eval $(call fuzz_bin_rule,$(t))))

# $(call fuzz_run,target,seconds,corpus dir,fresh): run one target, print
# one summary line, fail (log tail, reproducer) on any finding.
define fuzz_run
	@t=$(1); bin=$(FUZZ_OUT)/$$t; dir=$(FUZZ_OUT)/$(3); log=$$dir.log; \
	if [ "$(4)" = 1 ]; then rm -rf $$dir; fi; \
	mkdir -p $$dir && cp $(call fuzz_seeds,$(1))/* $$dir/ && \
	if ! $$bin -max_total_time=$(2) -timeout=$(FUZZ_TIMEOUT) -max_len=$(FUZZ_MAX_LEN_$(1)) \
	    -print_final_stats=1 -artifact_prefix=$(FUZZ_OUT)/$$t- $(FUZZ_FLAGS) $$dir >$$log 2>&1; then \
	  tail -n 30 $$log; echo ...; \
	  grep -E -A2 'check failed|ERROR: |runtime error|SUMMARY' $$log | head -n 12; \
	  echo "$$t: FAILED (log $$log; input $$(ls -t $(FUZZ_OUT)/$$t-* 2>/dev/null | head -n 1))"; \
	  exit 1; \
	fi; \
	printf '%-13s %10s execs in %3s s (%s/s), corpus %s inputs: ok\n' $$t \
	  "$$(sed -n 's/^stat::number_of_executed_units: *//p' $$log)" $(2) \
	  "$$(sed -n 's/^stat::average_exec_per_sec: *//p' $$log)" "$$(ls $$dir | wc -l)"
endef

$(FUZZ_RUNS): fuzz-run-%: $(FUZZ_OUT)/%
	$(call fuzz_run,$*,$(FUZZ_SECONDS),corpus-$*,0)

$(FUZZ_SMOKES): fuzz-smoke-%: $(FUZZ_OUT)/%
	$(call fuzz_run,$*,$(FUZZ_SMOKE_SECONDS),smoke-corpus-$*,1)

fuzz-clean:
	rm -rf $(FUZZ_OUT)

.DEFAULT_GOAL := $(FUZZ_SAVED_GOAL)
