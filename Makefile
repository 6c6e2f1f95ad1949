# Thin wrapper over CMake presets. `make demo` and `make test` are what the README's set-up
# commands run after scripts/install-deps.sh.
PRESET ?= release
BUILD_DIR := build/$(PRESET)
JOBS ?= $(shell nproc)

.PHONY: deps configure build demo test test-one test-release test-scalar test-asan test-fuzz fuzz bench \
	format clean

deps:
	bash scripts/install-deps.sh

configure:
	cmake --preset $(PRESET) >/dev/null

build: configure
	cmake --build --preset $(PRESET) -j $(JOBS)

demo: build
	$(BUILD_DIR)/apps/parallax/parallax demo

# The whole suite: the dispatched release build (every kernel path the CPU has), the scalar-only
# build (PLX_NO_SIMD), ASan + UBSan, and a bounded fuzz run of every decoder of untrusted bytes.
test: test-release test-scalar test-asan test-fuzz

# One preset's build and tests; the build's wall time is printed for CI's log (ctest prints the
# tests' own).
test-one:
	@start=$$(date +%s); $(MAKE) --no-print-directory build && \
		echo "== $(PRESET) build: $$(( $$(date +%s) - start )) s wall"
	ctest --preset $(PRESET) -j $(JOBS)

test-release:
	$(MAKE) test-one PRESET=release

test-scalar:
	$(MAKE) test-one PRESET=scalar

test-asan:
	$(MAKE) test-one PRESET=asan

# Bounded libFuzzer runs (clang, ASan + UBSan) of every decoder of untrusted bytes: PTM files,
# remote protocol messages and reference views, display and pose-path JSON, and the isolated
# import's scene wire form. FUZZ_SECONDS per target, two targets at a time.
FUZZ_SECONDS ?= 60
fuzz:
	scripts/fuzz.sh $(FUZZ_SECONDS)

# The fuzz run inside `make test`: seven targets of 45 s, two at a time, 3 minutes of wall time
# on CI's 2 cores (`make fuzz` runs longer).
test-fuzz:
	@start=$$(date +%s); $(MAKE) --no-print-directory fuzz FUZZ_SECONDS=45 && \
		echo "== fuzz build and runs: $$(( $$(date +%s) - start )) s wall"

bench: build
	scripts/run-benchmarks.sh $(BUILD_DIR)

format:
	find libs apps tests -name '*.cpp' -o -name '*.h' -o -name '*.inl' | xargs clang-format -i

clean:
	rm -rf build out
