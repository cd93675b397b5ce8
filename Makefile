# ghostsim - build, test, install.
#   make test      install missing Debian packages, build and run every test
#                  (plain, then under ASan+UBSan), compile checks, examples,
#                  all but the slow ones (make test-slow; .ci/run runs both)
#   make demo      three ghostpeer processes on loopback, live statistics,
#                  plots and a picture in demo-results/
#   make examples  build examples/ and the reference peer into build/
#   make valgrind  the test suite under valgrind (memcheck, leaks)
#   make fuzz      libFuzzer over decode, validation and blend for
#                  FUZZ_SECONDS (300), then over a keyed net's sealed path
#                  and over sequences of datagrams on moving clocks as
#                  long; summaries; `make test` runs 30 s + 15 s + 15 s
#   make install   PREFIX=/usr/local: the header, ghostsim.pc
#   make bench     every benchmark in bench/ (under 20 min on 2 cores):
#                  bench/results/*.json, REPORT.md and PNG plots
#   make bench-quick  the same with --quick (under 2 min; CI smoke test)
#   make faults    the fault suite (faults-short: its short form); make soak
# Every recipe is plain POSIX make + sh; nothing is downloaded except Debian
# packages through apt-get.

PREFIX   ?= /usr/local
CC       ?= cc
CXX      ?= c++
BUILD    := build
WARN     := -Wall -Wextra -Wpedantic -Werror
CSTD     := -std=c99 -D_POSIX_C_SOURCE=200809L
CFLAGS   ?= -O2 -g
SANFLAGS := -O1 -g -fsanitize=address,undefined -fno-omit-frame-pointer \
            -fno-sanitize-recover=all
CCD_CFLAGS = $(shell pkg-config --cflags ccd 2>/dev/null)
CCD_LIBS   = $(shell pkg-config --libs ccd 2>/dev/null)
LIBS      = $(CCD_LIBS) -lm -lpthread
# Sealed datagrams (libsodium): the tests and the peer are built with them;
# build/test_security_nosodium checks the build without.
SODIUM_CFLAGS := -DGHOSTSIM_SODIUM
SODIUM_LIBS   := -lsodium

# Debian packages the build and tests need (command or file that proves each).
DEBS := gcc g++ clang libclang-rt-dev make pkg-config cmake libccd-dev libcmocka-dev \
        valgrind libsdl2-dev gnuplot-nox python3 libsodium-dev
# And what the benchmarks need besides (bench/README.md).
BENCH_DEBS := libenet-dev libbullet-dev libode-dev gnuplot-nox hyperfine

TESTS    := $(basename $(notdir $(wildcard tests/test_*.c)))
# The same test files against an implementation built without
# GHOSTSIM_SODIUM (a key is GS_ERR_UNSUPPORTED there).
TESTS_NOSODIUM := test_security_nosodium
EXAMPLES := $(basename $(notdir $(wildcard examples/*.c)))

.PHONY: all deps deps-bench bench bench-quick bench-build test test-slow test-build test-plain test-asan tsan valgrind-udp \
        test-peers demo compile-checks examples peer valgrind install uninstall install-check \
        cmake-check clean fuzz fuzz-ci fuzz-ci-wire fuzz-ci-wire2 fuzz-ci-sealed \
        fuzz-ci-clock doc-check

all: examples

# Installs only what is missing, and only as root (CI and fresh machines).
define install_debs
@missing=""; for p in $(1); do \
  dpkg -s $$p >/dev/null 2>&1 || missing="$$missing $$p"; done; \
if [ -n "$$missing" ]; then \
  echo "deps: installing$$missing"; \
  if [ "$$(id -u)" != 0 ]; then echo "deps: run as root or install:$$missing" >&2; exit 1; fi; \
  apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq $$missing >/dev/null; \
fi
endef

deps:
	$(call install_debs,$(DEBS))

deps-bench:
	$(call install_debs,$(BENCH_DEBS))

$(BUILD) $(BUILD)/asan:
	mkdir -p $@

# One object holds the implementation; every test links it.
$(BUILD)/gs_impl.o: tests/gs_impl.c ghostsim.h | $(BUILD)
	$(CC) $(CSTD) $(WARN) $(CFLAGS) $(SODIUM_CFLAGS) $(CCD_CFLAGS) -I. -c $< -o $@
$(BUILD)/asan/gs_impl.o: tests/gs_impl.c ghostsim.h | $(BUILD)/asan
	$(CC) $(CSTD) $(WARN) $(SANFLAGS) $(SODIUM_CFLAGS) $(CCD_CFLAGS) -I. -c $< -o $@
$(BUILD)/gs_impl_nosodium.o: tests/gs_impl.c ghostsim.h | $(BUILD)
	$(CC) $(CSTD) $(WARN) $(CFLAGS) $(CCD_CFLAGS) -I. -c $< -o $@
$(BUILD)/asan/gs_impl_nosodium.o: tests/gs_impl.c ghostsim.h | $(BUILD)/asan
	$(CC) $(CSTD) $(WARN) $(SANFLAGS) $(CCD_CFLAGS) -I. -c $< -o $@

$(BUILD)/test_security_nosodium: tests/test_security.c $(BUILD)/gs_impl_nosodium.o ghostsim.h
	$(CC) $(CSTD) $(WARN) $(CFLAGS) -I. $< $(BUILD)/gs_impl_nosodium.o -o $@ -lcmocka $(LIBS)
$(BUILD)/asan/test_security_nosodium: tests/test_security.c $(BUILD)/asan/gs_impl_nosodium.o ghostsim.h
	$(CC) $(CSTD) $(WARN) $(SANFLAGS) -I. $< $(BUILD)/asan/gs_impl_nosodium.o -o $@ -lcmocka $(LIBS)
$(BUILD)/test_%: tests/test_%.c $(BUILD)/gs_impl.o ghostsim.h
	$(CC) $(CSTD) $(WARN) $(CFLAGS) $(SODIUM_CFLAGS) -I. $< $(BUILD)/gs_impl.o -o $@ -lcmocka $(LIBS) $(SODIUM_LIBS)
$(BUILD)/asan/test_%: tests/test_%.c $(BUILD)/asan/gs_impl.o ghostsim.h
	$(CC) $(CSTD) $(WARN) $(SANFLAGS) $(SODIUM_CFLAGS) -I. $< $(BUILD)/asan/gs_impl.o -o $@ -lcmocka $(LIBS) $(SODIUM_LIBS)
# The tests' shared helpers (tests/helpers.h: what they share; net_helpers.h: nets
# on the simnet, UDP and the test's own transport; alloc_helpers.h: the counting
# allocator; world_helpers.h: vectors, worlds and custom agents; wire_helpers.h:
# hand-built datagrams).
$(addprefix $(BUILD)/,$(TESTS) $(TESTS_NOSODIUM)) $(addprefix $(BUILD)/asan/,$(TESTS) $(TESTS_NOSODIUM)) \
  $(BUILD)/tsan/test_net: tests/helpers.h tests/net_helpers.h tests/alloc_helpers.h \
  tests/world_helpers.h tests/wire_helpers.h
# The regression test replays the fuzz harness's checks.
$(BUILD)/test_fuzz_regress $(BUILD)/asan/test_fuzz_regress: tests/fuzz_wire.c tests/fuzz_sealed.c \
  tests/fuzz_clock.c tests/fuzz_world.h

# The manual's quick starts (the top comment of ghostsim.h), extracted as
# functions that tests/test_manual.c runs: the manual cannot drift from
# what works.
$(BUILD)/manual_quickstart.h: ghostsim.h tests/manual_extract.py | $(BUILD)
	python3 tests/manual_extract.py ghostsim.h $@
$(BUILD)/test_manual $(BUILD)/asan/test_manual: $(BUILD)/manual_quickstart.h

# Every public declaration of ghostsim.h has its comment (tests/doc_check.py),
# and the manual's quick starts compile as C++11 too (test_manual runs them
# as C99).
doc-check: $(BUILD)/manual_quickstart.h
	@python3 tests/doc_check.py ghostsim.h
	@for cxx in g++ clang++; do \
	  $$cxx -std=c++11 $(WARN) $(SODIUM_CFLAGS) -I. -fsyntax-only -x c++ tests/test_manual.c || exit 1; \
	done; echo "doc-check: the quick starts compile as C++11 (g++, clang++)"

# The viewer needs SDL2 (Debian libsdl2-dev); its headless mode draws PNGs.
$(BUILD)/viewer: examples/viewer.c ghostsim.h | $(BUILD)
	$(CC) $(CSTD) $(WARN) $(CFLAGS) $(CCD_CFLAGS) -I. $< -o $@ \
	  $$(pkg-config --cflags --libs sdl2) $(LIBS)

$(BUILD)/%: examples/%.c ghostsim.h | $(BUILD)
	$(CC) $(CSTD) $(WARN) $(CFLAGS) $(CCD_CFLAGS) -I. $< -o $@ $(LIBS)

examples: $(addprefix $(BUILD)/,$(EXAMPLES)) peer

# The reference peer: build/ghostpeer, copied to reference_peer/ghostpeer
# (where the README and outside tests run it from).
peer: reference_peer/ghostpeer
$(BUILD)/ghostpeer: reference_peer/ghostpeer.c ghostsim.h | $(BUILD)
	$(CC) $(CSTD) $(WARN) $(CFLAGS) $(SODIUM_CFLAGS) $(CCD_CFLAGS) -I. $< -o $@ $(LIBS) $(SODIUM_LIBS)
reference_peer/ghostpeer: $(BUILD)/ghostpeer
	cp $< $@

# The header as C99 and C++11 under gcc and clang, with and without
# GHOSTSIM_STATIC and GHOSTSIM_SODIUM, implementation included: warning-free
# or the build fails (-fsyntax-only where the warnings all come from the
# front end, a third of the time; compiled where everything is static, as
# gcc says "defined but not used" after the front end). Once more at -O2 with
# everything static, where gcc inlines across the implementation and warns
# about what it then sees.
compile-checks: | $(BUILD)
	@mode() { case "$$1" in *STATIC*) echo "-c -o $(BUILD)/cc.o";; *) echo -fsyntax-only;; esac; }; \
	for f in compile_check compile_one; do \
	  for cc in gcc clang; do \
	    for opt in "" "-DGHOSTSIM_STATIC" "-DGHOSTSIM_SODIUM" "-DGHOSTSIM_SODIUM -DGHOSTSIM_STATIC"; do \
	      echo "compile-check: $$f $$cc -std=c99 $$opt"; \
	      $$cc -std=c99 $(WARN) $$opt -I. $$(mode "$$opt") tests/$$f.c || exit 1; \
	    done; done; \
	  for cxx in g++ clang++; do \
	    for opt in "" "-DGHOSTSIM_STATIC" "-DGHOSTSIM_SODIUM"; do \
	      echo "compile-check: $$f $$cxx -std=c++11 $$opt"; \
	      $$cxx -std=c++11 $(WARN) $$opt -I. -x c++ $$(mode "$$opt") tests/$$f.c || exit 1; \
	    done; done; done; \
	for cc in gcc clang; do \
	  echo "compile-check: compile_one $$cc -std=c99 -O2 -DGHOSTSIM_STATIC -DGHOSTSIM_SODIUM"; \
	  $$cc -std=c99 $(WARN) -O2 -DGHOSTSIM_STATIC -DGHOSTSIM_SODIUM -I. -c tests/compile_one.c \
	    -o $(BUILD)/cc.o || exit 1; done

test-plain: $(addprefix $(BUILD)/,$(TESTS) $(TESTS_NOSODIUM))
	@sh tests/run.sh "plain" $(addprefix $(BUILD)/,$(TESTS) $(TESTS_NOSODIUM))

test-asan: $(addprefix $(BUILD)/asan/,$(TESTS) $(TESTS_NOSODIUM))
	@ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1 \
	  sh tests/run.sh "asan+ubsan" $(addprefix $(BUILD)/asan/,$(TESTS) $(TESTS_NOSODIUM))

# make test runs each cmocka binary as a target of its own, two at a time,
# the longest first (under ASan the net and ghost suites are most of the
# time), so both cores stay busy to the end; test-plain and test-asan run
# them in one line each.
# The build without libsodium runs plain only (the sanitizers see the same
# code in the other suites), and the manual's quick starts run on a quiet
# machine, after: its UDP one must keep wall-clock pace.
# test_rest (the paper scene at rest after faults, on the simnet) runs plain
# only, in test-slow: under ASan it takes 2.5 minutes, and test_net puts the
# same sync code under the sanitizers. test_simd runs plain only (35 s under ASan, most of it the
# scene's settle): it compares the SIMD paths' bytes with plain C's, and the
# cloth suites run those paths under ASan.
SLOW_SUITES := test_delta test_ghost
PLAIN_ONLY := test_manual test_rest test_simd
# Under ASan in test-slow, which .ci/run runs after make test, plain in make
# test: test_converge (the paper scene's convergence on the simnet, 46 s
# under ASan on a 2-core machine), test_net (75 s: its scene and UDP runs;
# test-slow also runs its UDP tests under tsan and valgrind), test_scale
# and test_xpbd (32 s each: large cloths). make test's first phase was 546 s
# with them, at f8d97fb from a fresh clone.
ASAN_SLOW := test_converge test_net test_scale test_xpbd
SUITES_BY_LENGTH := $(addprefix run-asan-,$(SLOW_SUITES)) \
  $(addprefix run-asan-,$(filter-out $(SLOW_SUITES) $(PLAIN_ONLY) $(ASAN_SLOW),$(TESTS))) \
  $(addprefix run-plain-,$(filter-out test_manual test_rest,$(TESTS)) $(TESTS_NOSODIUM))
run-plain-%: $(BUILD)/%
	@sh tests/run.sh "plain" $(BUILD)/$*
run-asan-%: $(BUILD)/asan/%
	@ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1 \
	  sh tests/run.sh "asan+ubsan" $(BUILD)/asan/$*

# Everything `make test` runs, built first on both cores.
test-build: examples $(addprefix $(BUILD)/,$(TESTS) $(TESTS_NOSODIUM)) \
            $(addprefix $(BUILD)/asan/,$(TESTS) $(TESTS_NOSODIUM)) $(BUILD)/tsan/test_net \
            $(BUILD)/fuzz_wire $(BUILD)/fuzz_sealed $(BUILD)/fuzz_clock

# What only counts (the builds, compile checks, the fuzzers' fixed times,
# the cmocka suites) goes in one make, two jobs at a time, so that no core
# waits for a phase to end; each job's output is kept together. What
# measures wall-clock pace or convergence between processes (tsan on the
# UDP threads, the manual's UDP quick start, the peers, the fault suite)
# runs after, alone, as a loaded machine would fail it for the wrong
# reason (the peers and the fault suite side by side failed 3 scenarios of
# 5 where each alone passed). tests/phase.sh prints each part's time.
test: deps
	@sh tests/phase.sh "build, checks, fuzzers, cmocka suites" $(MAKE) --no-print-directory -j2 \
	  --output-sync=target fuzz-ci compile-checks $(SUITES_BY_LENGTH) doc-check examples \
	  cmake-check install-check $(BUILD)/test_net $(BUILD)/test_manual
	@sh tests/phase.sh "the manual over UDP" $(MAKE) --no-print-directory run-plain-test_manual
	@sh tests/phase.sh "peers" $(MAKE) --no-print-directory test-peers

# Suites too slow for make test's 10 minutes, which .ci/run runs after it:
# the paper scene's convergence on a perfect and a bad link (85 s of
# simulation; README "Convergence"), test_rest (the paper scene at rest
# after faults on the simnet, three seeds of the bad link), the UDP tests
# under ThreadSanitizer (90 s of CPU) and valgrind (leaks of sockets,
# threads and buffers; two minutes, one thread at a time), the short fault
# suite between ghostpeer processes in both sync modes (60 + 75 s) and the
# peers in replay (70 s). make test was 14 min 44 s
# with them on a loaded 2-core machine, 13 min 14 s on an idle one (phases
# 1-3: 503, 124, 166 s); each runs alone here, as each measures pace.
test-slow: $(BUILD)/test_net $(BUILD)/test_rest $(addprefix run-asan-,$(ASAN_SLOW))
	@GHOSTSIM_SLOW_TESTS=1 sh tests/run.sh "slow" "$(BUILD)/test_net test_scene_perfect_and_bad"
	@GHOSTSIM_SLOW_TESTS=1 sh tests/run.sh "slow" "$(BUILD)/test_rest"
	@$(MAKE) --no-print-directory tsan
	@$(MAKE) --no-print-directory faults-short
	@$(MAKE) --no-print-directory faults-short-replay
	@$(MAKE) --no-print-directory test-peers-replay
	@$(MAKE) --no-print-directory valgrind-udp

# The UDP tests (gather and scatter threads) under ThreadSanitizer, and under
# valgrind for leaks: sockets, threads and buffers all released at shutdown.
# valgrind runs one thread at a time; without --fair-sched=yes its lock let
# the simulation thread starve the gather thread (0 datagrams in 4 s).
TSANFLAGS := -O1 -g -fsanitize=thread -fno-omit-frame-pointer
$(BUILD)/tsan:
	mkdir -p $@
$(BUILD)/tsan/gs_impl.o: tests/gs_impl.c ghostsim.h | $(BUILD)/tsan
	$(CC) $(CSTD) $(WARN) $(TSANFLAGS) $(SODIUM_CFLAGS) $(CCD_CFLAGS) -I. -c $< -o $@
$(BUILD)/tsan/test_net: tests/test_net.c $(BUILD)/tsan/gs_impl.o ghostsim.h
	$(CC) $(CSTD) $(WARN) $(TSANFLAGS) $(SODIUM_CFLAGS) -I. $< $(BUILD)/tsan/gs_impl.o -o $@ -lcmocka $(LIBS) $(SODIUM_LIBS)
tsan: $(BUILD)/tsan/test_net
	@TSAN_OPTIONS="halt_on_error=1 second_deadlock_stack=1" \
	  sh tests/run.sh "tsan, udp" "$(BUILD)/tsan/test_net test_udp*"
valgrind-udp: $(BUILD)/test_net
	@VALGRIND="valgrind -q --fair-sched=yes --error-exitcode=99 --leak-check=full --errors-for-leak-kinds=definite,indirect" \
	  sh tests/run.sh "valgrind, udp" "$(BUILD)/test_net test_udp*"

# libFuzzer (clang; its runtime is Debian's libclang-rt-dev): the harnesses
# tests/fuzz_wire.c (datagrams in clear), tests/fuzz_sealed.c (a keyed
# net: the checks before decryption, the replay window, what it opens) and
# tests/fuzz_clock.c (programs of datagrams, round trips, advances and
# clock jumps: no time leaves its bounds), each with the library in one
# binary under ASan+UBSan, seeded with datagrams from the encoder
# (tests/fuzz_seeds.c). fuzz-ci is the bounded run of `make test`; each
# fails if the fuzzer finds anything.
FUZZ_SECONDS ?= 300
FUZZ_SEALED_SECONDS ?= $(FUZZ_SECONDS)
FUZZ_CLOCK_SECONDS ?= $(FUZZ_SECONDS)
FUZZ_CC      ?= clang
FUZZ_FLAGS   := -O1 -g -fsanitize=fuzzer,address,undefined -fno-sanitize-recover=all \
                -fno-omit-frame-pointer -fsanitize-coverage-ignorelist=tests/fuzz_ignore.txt
# The library is built once for the four harnesses (with GHOSTSIM_SODIUM,
# which the sealed harness needs and the others do not see): four builds of
# the implementation under these flags were a minute of make test's build.
$(BUILD)/fuzz:
	mkdir -p $@
$(BUILD)/fuzz/gs_impl.o: tests/gs_impl.c tests/fuzz_ignore.txt ghostsim.h | $(BUILD)/fuzz
	$(FUZZ_CC) $(CSTD) $(WARN) $(FUZZ_FLAGS) $(SODIUM_CFLAGS) $(CCD_CFLAGS) -I. -c $< -o $@
$(BUILD)/fuzz_wire: tests/fuzz_wire.c tests/fuzz_world.h $(BUILD)/fuzz/gs_impl.o ghostsim.h
	$(FUZZ_CC) $(CSTD) $(WARN) $(FUZZ_FLAGS) $(CCD_CFLAGS) -I. tests/fuzz_wire.c $(BUILD)/fuzz/gs_impl.o \
	  -o $@ $(LIBS) $(SODIUM_LIBS)
$(BUILD)/fuzz_wire2: tests/fuzz_wire2.c tests/fuzz_world.h $(BUILD)/fuzz/gs_impl.o ghostsim.h
	$(FUZZ_CC) $(CSTD) $(WARN) $(FUZZ_FLAGS) $(CCD_CFLAGS) -I. tests/fuzz_wire2.c $(BUILD)/fuzz/gs_impl.o \
	  -o $@ $(LIBS) $(SODIUM_LIBS)
$(BUILD)/fuzz_sealed: tests/fuzz_sealed.c tests/fuzz_wire.c tests/fuzz_world.h $(BUILD)/fuzz/gs_impl.o \
                      ghostsim.h
	$(FUZZ_CC) $(CSTD) $(WARN) $(FUZZ_FLAGS) $(SODIUM_CFLAGS) $(CCD_CFLAGS) -I. \
	  tests/fuzz_sealed.c $(BUILD)/fuzz/gs_impl.o -o $@ $(LIBS) $(SODIUM_LIBS)
$(BUILD)/fuzz_clock: tests/fuzz_clock.c tests/fuzz_world.h $(BUILD)/fuzz/gs_impl.o ghostsim.h
	$(FUZZ_CC) $(CSTD) $(WARN) $(FUZZ_FLAGS) $(CCD_CFLAGS) -I. tests/fuzz_clock.c $(BUILD)/fuzz/gs_impl.o \
	  -o $@ $(LIBS) $(SODIUM_LIBS)
$(BUILD)/fuzz_seeds: tests/fuzz_seeds.c tests/fuzz_world.h $(BUILD)/gs_impl.o ghostsim.h
	$(CC) $(CSTD) $(WARN) $(CFLAGS) -I. $< $(BUILD)/gs_impl.o -o $@ $(LIBS) $(SODIUM_LIBS)
$(BUILD)/fuzz-seeds.stamp: $(BUILD)/fuzz_seeds
	rm -rf $(BUILD)/fuzz-corpus && mkdir -p $(BUILD)/fuzz-corpus
	./$(BUILD)/fuzz_seeds $(BUILD)/fuzz-corpus
	touch $@

fuzz: deps
	@$(MAKE) --no-print-directory $(BUILD)/fuzz_wire $(BUILD)/fuzz_wire2 $(BUILD)/fuzz_sealed \
	  $(BUILD)/fuzz_clock $(BUILD)/fuzz-seeds.stamp
	@sh tests/fuzz_run.sh $(BUILD)/fuzz_wire $(FUZZ_SECONDS) fuzz
	@sh tests/fuzz_run.sh $(BUILD)/fuzz_wire2 $(FUZZ_SECONDS) fuzz
	@sh tests/fuzz_run.sh $(BUILD)/fuzz_sealed $(FUZZ_SEALED_SECONDS) fuzz
	@sh tests/fuzz_run.sh $(BUILD)/fuzz_clock $(FUZZ_CLOCK_SECONDS) fuzz

# 60 s in all, as before the clock harness came: the sealed path shares
# the wire's decode past the seal, and the clock harness's programs are
# short (48 operations) and reach their states within seconds. The
# quantized decoder's harness (fuzz_wire2) runs no world step per input,
# so its 10 s are hundreds of thousands of inputs; the full harness keeps 20.
fuzz-ci: fuzz-ci-wire fuzz-ci-wire2 fuzz-ci-sealed fuzz-ci-clock
fuzz-ci-wire: $(BUILD)/fuzz_wire $(BUILD)/fuzz-seeds.stamp
	@sh tests/fuzz_run.sh $(BUILD)/fuzz_wire 20 ci
fuzz-ci-wire2: $(BUILD)/fuzz_wire2 $(BUILD)/fuzz-seeds.stamp
	@sh tests/fuzz_run.sh $(BUILD)/fuzz_wire2 10 ci
fuzz-ci-sealed: $(BUILD)/fuzz_sealed $(BUILD)/fuzz-seeds.stamp
	@sh tests/fuzz_run.sh $(BUILD)/fuzz_sealed 15 ci
fuzz-ci-clock: $(BUILD)/fuzz_clock $(BUILD)/fuzz-seeds.stamp
	@sh tests/fuzz_run.sh $(BUILD)/fuzz_clock 15 ci

# ghostpeer processes on loopback (tests/peers.py: bounded, kills what it
# starts): two and three peers, a restart, a garbage flood, the command line.
# test-peers-replay: the same with every peer in --sync replay (issue 15:
# both suites in both modes; test-slow runs it).
.PHONY: test-peers-replay
test-peers: $(BUILD)/ghostpeer
	@python3 tests/peers.py $(BUILD)/ghostpeer
test-peers-replay: $(BUILD)/ghostpeer
	@GHOSTPEER_ARGS="--sync replay" python3 tests/peers.py $(BUILD)/ghostpeer

# The fault suite (tests/faults.py, README "Faults and soak"): ghostpeer
# processes behind a UDP proxy that drops, duplicates, reorders, delays,
# corrupts and cuts; a peer SIGKILLed and restarted, a clock step, a wild
# probe. faults: every scenario (about 3 min); faults-short: five of them
# (about 60 s; test-slow runs it); soak: four peers under rolling faults for
# SOAK_SECONDS. faults-replay and faults-short-replay: the same with every
# peer in --sync replay (the short one adds clock-fwd: about 75 s). No
# scenario is run twice: a retry would hide a convergence that is not
# reliable.
SOAK_SECONDS ?= 600
.PHONY: faults faults-short faults-replay faults-short-replay soak
faults: $(BUILD)/ghostpeer
	@python3 tests/faults.py $(BUILD)/ghostpeer
faults-short: $(BUILD)/ghostpeer
	@python3 tests/faults.py $(BUILD)/ghostpeer --short
faults-replay: $(BUILD)/ghostpeer
	@GHOSTPEER_ARGS="--sync replay" python3 tests/faults.py $(BUILD)/ghostpeer
faults-short-replay: $(BUILD)/ghostpeer
	@GHOSTPEER_ARGS="--sync replay" python3 tests/faults.py $(BUILD)/ghostpeer --short
soak: $(BUILD)/ghostpeer
	@python3 tests/faults.py $(BUILD)/ghostpeer --soak $(SOAK_SECONDS)

# Three peers on loopback for about 20 s with a live display; results and
# pictures in demo-results/.
# SYNC=replay runs the peers in replay mode (demo.py --sync).
SYNC ?= present
demo: deps
	@$(MAKE) --no-print-directory $(BUILD)/ghostpeer $(BUILD)/viewer
	@python3 reference_peer/demo.py --peer $(BUILD)/ghostpeer --viewer $(BUILD)/viewer \
	  --out demo-results --sync $(SYNC)

valgrind: $(addprefix $(BUILD)/,$(TESTS))
	@VALGRIND="valgrind -q --fair-sched=yes --error-exitcode=99 --leak-check=full --errors-for-leak-kinds=definite,indirect" \
	  sh tests/run.sh "valgrind" $(addprefix $(BUILD)/,$(TESTS))

# ---- benchmarks (bench/README.md) ----
# Every bench/*.c is C99 and every bench/*.cc C++11, built with the same
# warnings into build/bench/NAME. Extra flags for one program go in
# BENCH_LIBS_NAME. Library headers outside ours are -isystem, so their
# warnings do not fail -Werror.
BENCH_C      := $(basename $(notdir $(wildcard bench/*.c)))
BENCH_CC     := $(basename $(notdir $(wildcard bench/*.cc)))
BENCH_BINS   := $(addprefix $(BUILD)/bench/,$(BENCH_C) $(BENCH_CC))
BENCH_CFLAGS := -O2 -DNDEBUG
BENCH_LIBS_transport = -lenet
BENCH_LIBS_seal = -lsodium
BENCH_LIBS_physics = $(patsubst -I%,-isystem %,$(shell pkg-config --cflags bullet ode 2>/dev/null)) \
                     $(shell pkg-config --libs bullet ode 2>/dev/null)
BENCH_TIMEOUT_FULL  := 900
BENCH_TIMEOUT_QUICK := 100

$(BUILD)/bench:
	mkdir -p $@
$(BUILD)/bench/%: bench/%.c bench/bench_util.h bench/equal_time.h ghostsim.h | $(BUILD)/bench
	$(CC) $(CSTD) $(WARN) $(BENCH_CFLAGS) $(CCD_CFLAGS) -I. $< -o $@ $(BENCH_LIBS_$*) $(LIBS)
$(BUILD)/bench/%: bench/%.cc bench/bench_util.h ghostsim.h | $(BUILD)/bench
	$(CXX) -std=c++11 $(WARN) $(BENCH_CFLAGS) $(CCD_CFLAGS) -I. $< -o $@ $(BENCH_LIBS_$*) $(LIBS)

bench-build: $(BENCH_BINS)

# Benchmarks in Python (standard library only) that drive ghostpeer
# processes; bench/run.sh runs them as it runs the programs.
BENCH_PY := bench/process_gap.py bench/peer_cpu.py

# Runs every program (a failure does not stop the others, but fails the
# target), then bench/report.py draws the report and the plots.
bench: deps deps-bench
	@$(MAKE) --no-print-directory bench-build $(BUILD)/ghostpeer
	@GHOSTPEER=$(BUILD)/ghostpeer sh bench/run.sh "" $(BENCH_TIMEOUT_FULL) $(BENCH_BINS) $(BENCH_PY)

bench-quick: deps deps-bench
	@$(MAKE) --no-print-directory bench-build $(BUILD)/ghostpeer
	@GHOSTPEER=$(BUILD)/ghostpeer sh bench/run.sh --quick $(BENCH_TIMEOUT_QUICK) $(BENCH_BINS) $(BENCH_PY)

ghostsim.pc: ghostsim.pc.in Makefile
	sed -e 's|@PREFIX@|$(PREFIX)|' -e 's|@VERSION@|0.1.0|' $< > $@

install: ghostsim.pc
	install -d $(DESTDIR)$(PREFIX)/include $(DESTDIR)$(PREFIX)/lib/pkgconfig
	install -m 644 ghostsim.h $(DESTDIR)$(PREFIX)/include/ghostsim.h
	install -m 644 ghostsim.pc $(DESTDIR)$(PREFIX)/lib/pkgconfig/ghostsim.pc
	rm -f ghostsim.pc

uninstall:
	rm -f $(DESTDIR)$(PREFIX)/include/ghostsim.h $(DESTDIR)$(PREFIX)/lib/pkgconfig/ghostsim.pc

# Installs into a scratch prefix and builds an example through pkg-config.
install-check: | $(BUILD)
	@rm -rf $(BUILD)/prefix
	@$(MAKE) --no-print-directory -s install PREFIX=$(CURDIR)/$(BUILD)/prefix
	@PKG_CONFIG_PATH=$(CURDIR)/$(BUILD)/prefix/lib/pkgconfig; export PKG_CONFIG_PATH; \
	  $(CC) $(CSTD) $(WARN) examples/hello_cloth.c -o $(BUILD)/hello_pc \
	    $$(pkg-config --cflags --libs ghostsim) && ./$(BUILD)/hello_pc >/dev/null && \
	  echo "install-check: pkg-config ghostsim builds and runs hello_cloth"

# A CMake project that uses the INTERFACE target through add_subdirectory.
cmake-check: | $(BUILD)
	@rm -rf $(BUILD)/cmake && \
	  cmake -S tests/cmake_consumer -B $(BUILD)/cmake >/dev/null && \
	  cmake --build $(BUILD)/cmake >/dev/null && ./$(BUILD)/cmake/consumer >/dev/null && \
	  echo "cmake-check: add_subdirectory + ghostsim::ghostsim builds and runs hello_cloth"

clean:
	rm -rf $(BUILD) ghostsim.pc
