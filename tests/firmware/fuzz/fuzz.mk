# tests/firmware/fuzz/fuzz.mk - libFuzzer targets for the firmware's modules (and,
# in fuzz_line, the whole device on tests/firmware/native's fakes), built natively
# with clang (Debian's clang-14 + libclang-rt-14-dev) under
# AddressSanitizer and UndefinedBehaviorSanitizer, any finding fatal.
#
#   make fuzz [FUZZ_SECONDS=N]   build all targets into $(BUILD)/fuzz/, run
#                                each N seconds (default 10), then print a
#                                table: executions, executions a second,
#                                coverage (edges) and features at the end;
#                                fails on any crash, sanitizer report, failed
#                                check or hang
#   make fuzz-smoke              the short run of `make test` (FUZZ_SMOKE_SECONDS
#                                a target, from the repo's corpus; see below
#                                for how it was chosen), same table
#   make fuzz-corpus             minimize (-merge=1) the repo's corpus together
#                                with what `make fuzz` found, into the repo's
#                                corpus (review and commit the change); inputs
#                                named by hand are kept as they are
#   make fuzz-clean              remove $(BUILD)/fuzz
#
# Targets (tests/firmware/fuzz/<target>.c; corpus in tests/firmware/fuzz/corpus/<target>/):
#   fuzz_command   command_parse() on arbitrary lines, up to FUZZ_COMMAND_MAX_LEN
#                  bytes: result codes, blank lines, case, blanks, determinism
#   fuzz_cmdline   the console's receiver and line editor (echo off) with the
#                  parser, on whole byte streams, against a model of the lines
#   fuzz_proto     proto_* framing, crc16, fmt_u32/fmt_hex vs an independent
#                  decoder, CRC and snprintf; corrupted lines never accepted
#   fuzz_fmt       fmt_adev/fmt_tau/fmt_sig3: 3 significant digits vs double
#   fuzz_allan     the Allan engine vs an exact 128-bit reference, every
#                  level (default build: 15 levels, 48-bit from level 11);
#                  inputs start empty or from snapshots near the high levels
#   fuzz_allan20   the same with -DALLAN_LEVELS=20 -DALLAN_ACC48_FROM=0
#   fuzz_line      the whole device natively (tests/firmware/native's fakes) on byte
#                  streams with mode changes, Ctrl-C/Esc, overruns, framing
#                  errors and line timeouts: every line run is one clean line as sent, in
#                  order; all of them with no ring overflow; Ctrl-C + command
#                  runs in every mode; never deaf
# Each run works on a copy of the corpus in $(BUILD)/fuzz/corpus-<target>,
# which keeps what it found for the next `make fuzz` (fuzz-smoke starts
# from the repo's corpus alone each time, in smoke-corpus-<target>); the
# repo's corpus is written only by `make fuzz-corpus`.  A failure prints
# the log's tail and leaves the input as $(BUILD)/fuzz/<target>-crash-*
# (or -timeout-*, -oom-*); replay it with `$(BUILD)/fuzz/<target> FILE`.
#
# Included by the top-level Makefile (which defines BUILD and FW_DIR); on its
# own: make -f tests/firmware/fuzz/fuzz.mk fuzz

# Keep the including Makefile's default goal.
FUZZ_SAVED_GOAL := $(.DEFAULT_GOAL)

BUILD ?= build
FW_DIR ?= firmware
FUZZ_SECONDS ?= 10
# The smoke run's budget, a target, where new coverage stops.  Measured with
# tests/firmware/fuzz/saturation.py on 2 cores shared with other work (load 11-13:
# each run got about a fifth of a core), seconds until the edges (cov)
# reach their final count, and features (ft) 99 % of theirs:
#                  from nothing, 45 s             from the repo's corpus, 20 s
#                  edges   ft99   edges/ft at 45  edges   ft99   edges at start
#   fuzz_command    13.4   38.9    101/363          0.2    0.2   134 = final
#   fuzz_cmdline    35.1   24.2    120/773          0.3    0.3   136 = final
#   fuzz_proto       8.4   32.0    190/1052         0.5   11.9   190 = final
#   fuzz_fmt         1.2    1.4    118/347          0.3    0.3   118 = final
#   fuzz_allan       2.8   37.2    244/1515         0.7    1.5   244 = final
#   fuzz_allan20    40.8   37.9    266/1613         3.8    4.4   265 = final
#   fuzz_line       40.8   41.9    907/3954         4.1   12.8   930 = final
# ("edges" from the corpus: when the first status line came, the corpus
# replayed.)  From nothing, no target but fuzz_fmt saturates within a minute
# here, so the corpus carries the saturation (`make fuzz-corpus` after
# longer runs: fuzz_line's from 150 s and 90 s) and the smoke run starts from it:
# 5 s a target reach every final edge count, and the features' 99 %
# but fuzz_proto's; fuzz_line, which replays its corpus in ~5 s here, gets
# 10 s.  Seven targets: ~40 s of fuzzing, 92 s with a clean build here.
FUZZ_SMOKE_SECONDS ?= 5
FUZZ_SMOKE_SECONDS_fuzz_line ?= 10
# The smoke run of `make test` mutates from a fixed seed, so a CI verdict
# does not depend on a draw: it replays the corpus and a fixed stretch of
# mutations (how far it gets still depends on the machine's speed).
# Exploration is `make fuzz`'s job (FUZZ_FLAGS=-seed=N to vary it there).
FUZZ_SMOKE_SEED ?= 1
# Seconds one input may take before it counts as a hang.
FUZZ_TIMEOUT ?= 20
# More libFuzzer flags, e.g. -seed=1 or -jobs=4.
FUZZ_FLAGS ?=
# Longer than the device's line (COMMAND_LINE_MAX) by far, since the parser
# takes any string; below 65536, where a word makes command_parse() loop
# forever (word_len()'s 16-bit count wraps to 0 and starts again).
FUZZ_COMMAND_MAX_LEN ?= 1024

FUZZ_CC ?= $(shell command -v clang-14 || command -v clang)
FUZZ_DIR := tests/firmware/fuzz
FUZZ_OUT := $(BUILD)/fuzz
FUZZ_CFLAGS := -std=gnu99 -g -O1 -fsanitize=fuzzer,address,undefined -fno-sanitize-recover=all \
               -Wall -Wextra -Werror -I $(FW_DIR) -I $(FUZZ_DIR)
FUZZ_DEPS := $(wildcard $(FW_DIR)/*.h) $(FUZZ_DIR)/fuzz_util.h $(FUZZ_DIR)/fuzz.mk \
             $(FUZZ_DIR)/fuzz_line_state.h tests/firmware/native/fixture.h tests/firmware/native/fake_device.c

FUZZ_TARGETS := fuzz_command fuzz_cmdline fuzz_proto fuzz_fmt fuzz_allan fuzz_allan20 fuzz_line
FUZZ_SMOKE_TARGETS := $(FUZZ_TARGETS)

# Per target: firmware sources, extra flags, seed directory, input size.
FUZZ_SRC_fuzz_command := command.c vocab.c
# The console's receiver with the parser, on whole byte streams (NULs and all bytes).
FUZZ_SRC_fuzz_cmdline := console.c command.c vocab.c proto.c crc.c fmt.c
FUZZ_XFLAGS_fuzz_cmdline := -DF_CPU=10000000UL
# The whole device with tests/firmware/native's fakes (included by fuzz_line.c).
FUZZ_SRC_fuzz_line := loop.c switchboard.c report.c reply.c stream.c control.c console.c sample.c settings.c \
                      command.c vocab.c link.c proto.c crc.c fmt.c allan.c units.c
FUZZ_SRC_fuzz_proto := proto.c crc.c fmt.c
FUZZ_SRC_fuzz_fmt := fmt.c
FUZZ_SRC_fuzz_allan := allan.c
FUZZ_SRC_fuzz_allan20 := allan.c
# The engine targets run up to a thousand sets an input: comparison
# tracing (the fuzzer's value profile) would halve their speed for little
# gain, and -O2 nearly doubles it (sanitizers and checks stay).  Inputs a
# second of CPU, 10 s runs from each one's corpus, three alternated pairs,
# median (min-max), against the fuzzer they replaced (up to 2^16-2^17 sets
# an input, every level read after each of the first 4096, -O1):
#   fuzz_allan     25 (21-37)  ->  2860 (2782-3385)
#   fuzz_allan20   17 (14-28)  ->  2107 (1954-2198)
FUZZ_XFLAGS_fuzz_allan := -O2 -fno-sanitize-coverage=trace-cmp
FUZZ_XFLAGS_fuzz_allan20 := $(FUZZ_XFLAGS_fuzz_allan) -DALLAN_LEVELS=20 -DALLAN_ACC48_FROM=0
FUZZ_MAIN_fuzz_allan20 := fuzz_allan
FUZZ_XFLAGS_fuzz_line := -I tests/firmware/native -isystem tests/firmware/native/fake -DF_CPU=10000000UL -DBAUD=115200UL \
                         -DBOARD_PROBES=0 -include $(FUZZ_DIR)/fuzz_line_state.h -Wl,--wrap=command_parse
FUZZ_MAX_LEN_fuzz_command = $(FUZZ_COMMAND_MAX_LEN)
FUZZ_MAX_LEN_fuzz_cmdline := 512
FUZZ_MAX_LEN_fuzz_line := 512
FUZZ_MAX_LEN_fuzz_proto := 1024
FUZZ_MAX_LEN_fuzz_fmt := 32
FUZZ_MAX_LEN_fuzz_allan := 1024
FUZZ_MAX_LEN_fuzz_allan20 := 1024

fuzz_main = $(FUZZ_DIR)/$(or $(FUZZ_MAIN_$(1)),$(1)).c
fuzz_seeds = $(FUZZ_DIR)/corpus/$(1)

FUZZ_BINS := $(addprefix $(FUZZ_OUT)/,$(FUZZ_TARGETS))
FUZZ_RUNS := $(addprefix fuzz-run-,$(FUZZ_TARGETS))
FUZZ_SMOKES := $(addprefix fuzz-smoke-,$(FUZZ_SMOKE_TARGETS))

.PHONY: fuzz fuzz-smoke fuzz-build fuzz-corpus fuzz-clean $(FUZZ_RUNS) $(FUZZ_SMOKES)

fuzz-build: $(FUZZ_BINS) ## build the fuzzers into build/fuzz/

define fuzz_bin_rule
$(FUZZ_OUT)/$(1): $(call fuzz_main,$(1)) $(addprefix $(FW_DIR)/,$(FUZZ_SRC_$(1))) $(FUZZ_DEPS)
	@test -n "$(FUZZ_CC)" || { echo "fuzz: no clang-14 or clang (apt-get install clang-14 libclang-rt-14-dev)"; exit 1; }
	@mkdir -p $(FUZZ_OUT)
	$(FUZZ_CC) $(FUZZ_CFLAGS) $(FUZZ_XFLAGS_$(1)) $$(filter-out tests/firmware/native/%,$$(filter %.c,$$^)) -lm -o $$@
endef
$(foreach t,$(FUZZ_TARGETS),$(eval $(call fuzz_bin_rule,$(t))))

# $(call fuzz_run,target,seconds,corpus dir,fresh): run one target, keep
# its numbers in <dir>.row for the table, fail (log tail, reproducer) on
# any finding.
define fuzz_run
	@t=$(1); bin=$(FUZZ_OUT)/$$t; dir=$(FUZZ_OUT)/$(3); log=$$dir.log; \
	if [ "$(4)" = 1 ]; then rm -rf $$dir; fi; \
	rm -f $$dir.row; mkdir -p $$dir && cp $(call fuzz_seeds,$(1))/* $$dir/ && \
	if ! $$bin -max_total_time=$(2) -timeout=$(FUZZ_TIMEOUT) -max_len=$(FUZZ_MAX_LEN_$(1)) \
	    -print_final_stats=1 -artifact_prefix=$(FUZZ_OUT)/$$t- $(if $(filter 1,$(4)),-seed=$(FUZZ_SMOKE_SEED)) \
	    $(FUZZ_FLAGS) $$dir >$$log 2>&1; then \
	  tail -n 30 $$log; echo ...; \
	  grep -E -A2 'check failed|ERROR: |runtime error|SUMMARY' $$log | head -n 12; \
	  echo "$$t: FAILED (log $$log; input $$(ls -t $(FUZZ_OUT)/$$t-* 2>/dev/null | head -n 1))"; \
	  exit 1; \
	fi; \
	done=$$(grep -E '^#[0-9]+[[:space:]]+DONE' $$log | tail -n 1); \
	printf '%-13s %6s %10s %8s %6s %7s %7s\n' $$t $(2) \
	  "$$(sed -n 's/^stat::number_of_executed_units: *//p' $$log)" \
	  "$$(sed -n 's/^stat::average_exec_per_sec: *//p' $$log)" \
	  "$$(echo "$$done" | sed -n 's/.* cov: \([0-9]*\).*/\1/p')" \
	  "$$(echo "$$done" | sed -n 's/.* ft: \([0-9]*\).*/\1/p')" \
	  "$$(ls $$dir | wc -l)" >$$dir.row; \
	echo "$$t: ok"
endef

# $(call fuzz_table,corpus dir prefix,targets): the runs' rows under one header.
define fuzz_table
	@printf '%-13s %6s %10s %8s %6s %7s %7s\n' target secs execs execs/s cov ft corpus
	@cat $(foreach t,$(2),$(FUZZ_OUT)/$(1)$(t).row)
endef

$(FUZZ_RUNS): fuzz-run-%: $(FUZZ_OUT)/% ## fuzz-run-<target>: one fuzzer (e.g. fuzz-run-fuzz_proto) FUZZ_SECONDS
	$(call fuzz_run,$*,$(FUZZ_SECONDS),corpus-$*,0)

$(FUZZ_SMOKES): fuzz-smoke-%: $(FUZZ_OUT)/% ## fuzz-smoke-<target>: one fuzzer's short run from the repo's corpus
	$(call fuzz_run,$*,$(or $(FUZZ_SMOKE_SECONDS_$*),$(FUZZ_SMOKE_SECONDS)),smoke-corpus-$*,1)

fuzz: $(FUZZ_RUNS) ## run every fuzzer FUZZ_SECONDS (default 10) under ASan and UBSan; a table of execs/s and coverage
	$(call fuzz_table,corpus-,$(FUZZ_TARGETS))

fuzz-smoke: $(FUZZ_SMOKES) ## every fuzzer 5 s (fuzz_line 10 s) from the repo's corpus, the same table (part of make test)
	$(call fuzz_table,smoke-corpus-,$(FUZZ_SMOKE_TARGETS))

# -merge=1 into an empty directory keeps the fewest inputs that give every
# feature of the repo's corpus and of what `make fuzz` found; inputs named
# by hand (not a 40-digit hash: seeds, bugs' reproducers) always stay.
FUZZ_CORPORA := $(addprefix fuzz-corpus-,$(FUZZ_TARGETS))
.PHONY: $(FUZZ_CORPORA)
fuzz-corpus: $(FUZZ_CORPORA) ## minimize (-merge=1) the repo's corpus with what make fuzz found, into tests/firmware/fuzz/corpus/
$(FUZZ_CORPORA): fuzz-corpus-%: $(FUZZ_OUT)/% ## fuzz-corpus-<target>: one fuzzer's corpus minimized into the repo
	@new=$(FUZZ_OUT)/merge-$*; rm -rf $$new; mkdir -p $$new $(FUZZ_OUT)/corpus-$*; \
	$(FUZZ_OUT)/$* -merge=1 -max_len=$(FUZZ_MAX_LEN_$*) $$new $(FUZZ_DIR)/corpus/$* \
	  $(FUZZ_OUT)/corpus-$* >$$new.log 2>&1 || { tail -n 20 $$new.log; exit 1; }; \
	find $(FUZZ_DIR)/corpus/$* -type f -regextype egrep -regex '.*/[0-9a-f]{40}' -delete; \
	cp $$new/* $(FUZZ_DIR)/corpus/$*/; \
	echo "$*: $$(ls $$new | wc -l) inputs, $$(cat $$new/* | wc -c) bytes"

fuzz-clean: ## remove build/fuzz (the fuzzers and the corpora they grew)
	rm -rf $(FUZZ_OUT)

.DEFAULT_GOAL := $(FUZZ_SAVED_GOAL)
