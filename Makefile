# The two commands of the README (`make demo`, `make test`) and their companions.
# Each installs what is missing, configures with CMake and builds with as many jobs as cores.

JOBS      ?= $(shell nproc 2>/dev/null || echo 2)
PREFIX    ?= /usr/local
BUILD_DIR ?= build
CMAKE     ?= cmake
OUT       ?= out

RELEASE_DIR := $(BUILD_DIR)/release
TEST_DIR    := $(BUILD_DIR)/test
ASAN_DIR    := $(BUILD_DIR)/asan

.PHONY: all deps demo test bench asan install clean format

all: test

deps:
	@scripts/install-deps.sh

# Release build for the demo, the benchmarks and install.
$(RELEASE_DIR)/CMakeCache.txt: | deps
	$(CMAKE) -S . -B $(RELEASE_DIR) -DCMAKE_BUILD_TYPE=Release -DSWERVE_BUILD_TESTS=OFF

# Optimised test build with the internal invariant checks (SWERVE_DCHECK) switched on.
$(TEST_DIR)/CMakeCache.txt: | deps
	$(CMAKE) -S . -B $(TEST_DIR) -DCMAKE_BUILD_TYPE=RelWithDebInfo -DSWERVE_ENABLE_DCHECKS=ON \
	  -DSWERVE_BUILD_BENCHMARKS=OFF -DSWERVE_WARNINGS_AS_ERRORS=ON

$(ASAN_DIR)/CMakeCache.txt: | deps
	$(CMAKE) -S . -B $(ASAN_DIR) -DCMAKE_BUILD_TYPE=Debug -DSWERVE_SANITIZE=ON -DSWERVE_BUILD_BENCHMARKS=OFF

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

install: deps $(RELEASE_DIR)/CMakeCache.txt
	$(CMAKE) --build $(RELEASE_DIR) -j $(JOBS)
	$(CMAKE) --install $(RELEASE_DIR) --prefix $(PREFIX)

format:
	find include src models solvers tests bench examples -name '*.[ch]pp' | xargs clang-format -i

clean:
	rm -rf $(BUILD_DIR) $(OUT)
