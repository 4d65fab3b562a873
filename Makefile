# The two commands of the README (`make demo`, `make test`) and their companions.
# Each installs what is missing, configures with CMake and builds with as many jobs as cores;
# `make fuzz` (clang's libFuzzer) runs the fuzz targets of tests/fuzz.

JOBS      ?= $(shell nproc 2>/dev/null || echo 2)
PREFIX    ?= /usr/local
BUILD_DIR ?= build
CMAKE     ?= cmake
OUT       ?= out

RELEASE_DIR := $(BUILD_DIR)/release
TEST_DIR    := $(BUILD_DIR)/test
ASAN_DIR    := $(BUILD_DIR)/asan
TSAN_DIR    := $(BUILD_DIR)/tsan
FUZZ_DIR    := $(BUILD_DIR)/fuzz
ARM64_DIR   := $(BUILD_DIR)/arm64
ARM64_SYSROOT := $(abspath $(ARM64_DIR))/sysroot

# `make fuzz`: executions per fuzz target, CI-sized (each well under a minute here; a controller
# step solves an OCP, so that target runs ~30x fewer inputs a second), and libFuzzer's other flags.
FUZZ_RUNS_config          ?= 20000
FUZZ_RUNS_controller_step ?= 2000
FUZZ_ARGS ?= -max_len=4096 -timeout=10 -rss_limit_mb=4096 -print_final_stats=1
FUZZERS   := config controller_step

.PHONY: all deps fuzz-deps cross-deps demo test bench asan tsan fuzz cross-arm64 install clean format

all: test

deps:
	@scripts/install-deps.sh

# clang and its libFuzzer runtime, needed by `make fuzz` only.
fuzz-deps:
	@scripts/install-deps.sh fuzz

# The aarch64 cross toolchain and qemu-user, and the arm64 libraries unpacked into a sysroot,
# needed by `make cross-arm64` only.
cross-deps:
	@scripts/install-deps.sh cross-arm64
	@scripts/arm64-sysroot.sh $(ARM64_SYSROOT)

# Release build for the demo, the benchmarks and install.
$(RELEASE_DIR)/CMakeCache.txt: | deps
	$(CMAKE) -S . -B $(RELEASE_DIR) -DCMAKE_BUILD_TYPE=Release -DSWERVE_BUILD_TESTS=OFF

# Optimised test build with the internal invariant checks (SWERVE_DCHECK) switched on.
# -g1 (function names and line tables: backtraces, not locals) instead of -g: on the 2-core CI
# machine the suite built in 9.7 min against 13.9 with full debug information, which kept
# `make test` past its 15 min. Debug a test in a build of your own.
$(TEST_DIR)/CMakeCache.txt: | deps
	$(CMAKE) -S . -B $(TEST_DIR) -DCMAKE_BUILD_TYPE=RelWithDebInfo -DSWERVE_ENABLE_DCHECKS=ON \
	  -DSWERVE_BUILD_BENCHMARKS=OFF -DSWERVE_WARNINGS_AS_ERRORS=ON "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O2 -g1 -DNDEBUG"

# Sanitized at -O2 with assertions and SWERVE_DCHECK kept (no NDEBUG): an -O0 build spent ~1 h in
# ctest, almost all of it in Eigen's unoptimised expression templates, which hides nothing ASan or
# UBSan would find at -O2 and made `make asan` too slow to run twice under load.
$(ASAN_DIR)/CMakeCache.txt: | deps
	$(CMAKE) -S . -B $(ASAN_DIR) -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O2 -g" \
	  -DSWERVE_ENABLE_DCHECKS=ON -DSWERVE_SANITIZE=ON -DSWERVE_BUILD_BENCHMARKS=OFF

# ThreadSanitizer: the tests whose code runs on several threads (SA's, with its workers sharing a
# work clock and the model's charges, and the polish's gradient shares; the controller suite). The
# rest of the solver suite is single-threaded and takes ~8 min under TSan.
$(TSAN_DIR)/CMakeCache.txt: | deps
	$(CMAKE) -S . -B $(TSAN_DIR) -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g" \
	  -DSWERVE_TSAN=ON -DSWERVE_BUILD_BENCHMARKS=OFF

# clang with libFuzzer, ASan and UBSan; only the fuzz targets and what they link (tests/fuzz).
$(FUZZ_DIR)/CMakeCache.txt: | fuzz-deps
	CC=clang CXX=clang++ $(CMAKE) -S . -B $(FUZZ_DIR) -DCMAKE_BUILD_TYPE=RelWithDebInfo -DSWERVE_BUILD_FUZZERS=ON \
	  -DSWERVE_ENABLE_DCHECKS=ON -DSWERVE_BUILD_TESTS=OFF -DSWERVE_BUILD_BENCHMARKS=OFF -DSWERVE_BUILD_CLI=OFF

# Cross-built for aarch64 (the Raspberry Pi 4 and Jetson targets' architecture) with the test
# build's settings: the core library, the SA and NLopt backends, the CLI and the test suites
# (Ipopt's and Ceres' arm64 packages cannot be installed beside the host's; see docs/benchmarks.md).
$(ARM64_DIR)/CMakeCache.txt: | cross-deps
	$(CMAKE) -S . -B $(ARM64_DIR) -DCMAKE_TOOLCHAIN_FILE=$(CURDIR)/cmake/toolchains/aarch64-linux-gnu.cmake \
	  -DSWERVE_ARM64_SYSROOT=$(ARM64_SYSROOT) -DCMAKE_BUILD_TYPE=RelWithDebInfo -DSWERVE_ENABLE_DCHECKS=ON \
	  -DSWERVE_BUILD_BENCHMARKS=OFF -DSWERVE_BUILD_PYTHON=OFF -DSWERVE_WARNINGS_AS_ERRORS=ON \
	  -DCMAKE_DISABLE_FIND_PACKAGE_Ceres=ON -DCMAKE_DISABLE_FIND_PACKAGE_PkgConfig=ON

demo: deps $(RELEASE_DIR)/CMakeCache.txt
	$(CMAKE) --build $(RELEASE_DIR) -j $(JOBS)
	@scripts/demo.sh $(RELEASE_DIR) $(OUT)

test: deps $(TEST_DIR)/CMakeCache.txt
	$(CMAKE) --build $(TEST_DIR) -j $(JOBS)
	cd $(TEST_DIR) && ctest --output-on-failure -j $(JOBS)

bench: deps $(RELEASE_DIR)/CMakeCache.txt
	$(CMAKE) --build $(RELEASE_DIR) -j $(JOBS) --target swerve_bench
	$(RELEASE_DIR)/bench/swerve_bench --benchmark_counters_tabular=true $(BENCH_ARGS)

asan: deps $(ASAN_DIR)/CMakeCache.txt
	$(CMAKE) --build $(ASAN_DIR) -j $(JOBS)
	cd $(ASAN_DIR) && ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1 ctest --output-on-failure -j $(JOBS)

tsan: deps $(TSAN_DIR)/CMakeCache.txt
	$(CMAKE) --build $(TSAN_DIR) -j $(JOBS) --target solver_tests control_tests
	TSAN_OPTIONS="halt_on_error=1 second_deadlock_stack=1" $(TSAN_DIR)/tests/solvers/solver_tests --gtest_brief=1 \
	  --gtest_filter='SimulatedAnnealing.*'
	TSAN_OPTIONS="halt_on_error=1 second_deadlock_stack=1" $(TSAN_DIR)/tests/control/control_tests --gtest_brief=1

# Builds the fuzz targets and runs each for FUZZ_RUNS_<name> executions on a fresh copy of its
# committed corpus (tests/fuzz/corpus/<name>/ -> $(FUZZ_DIR)/corpus/<name>/); any finding fails,
# and its input lands in $(FUZZ_DIR)/findings/<name>/ (crash-*, leak-*, timeout-*, oom-*).
define run_fuzzer
	rm -rf $(FUZZ_DIR)/corpus/$(1) && mkdir -p $(FUZZ_DIR)/corpus/$(1) $(FUZZ_DIR)/findings/$(1)
	cp tests/fuzz/corpus/$(1)/* $(FUZZ_DIR)/corpus/$(1)/
	$(FUZZ_DIR)/tests/fuzz/$(1)_fuzzer -runs=$(FUZZ_RUNS_$(1)) $(FUZZ_ARGS) \
	  -artifact_prefix=$(FUZZ_DIR)/findings/$(1)/ $(FUZZ_DIR)/corpus/$(1)

endef

fuzz: fuzz-deps $(FUZZ_DIR)/CMakeCache.txt
	$(CMAKE) --build $(FUZZ_DIR) -j $(JOBS) --target $(addsuffix _fuzzer,$(FUZZERS))
	$(foreach name,$(FUZZERS),$(call run_fuzzer,$(name)))
# Under qemu-aarch64: the unit tests, the CLI tests and the cross-architecture scenario check
# (cli.ShortScenarioMatchesTheReferenceSummary). The layer check needs no emulation and runs too.
cross-arm64: cross-deps $(ARM64_DIR)/CMakeCache.txt
	$(CMAKE) --build $(ARM64_DIR) -j $(JOBS)
	cd $(ARM64_DIR) && ctest --output-on-failure -j $(JOBS)

install: deps $(RELEASE_DIR)/CMakeCache.txt
	$(CMAKE) --build $(RELEASE_DIR) -j $(JOBS)
	$(CMAKE) --install $(RELEASE_DIR) --prefix $(PREFIX)

format:
	find include src models solvers tests bench examples -name '*.[ch]pp' | xargs clang-format -i

clean:
	rm -rf $(BUILD_DIR) $(OUT)
