# Thin wrapper over CMake presets. `make demo` and `make test` are what the README's set-up
# commands run after scripts/install-deps.sh.
PRESET ?= release
BUILD_DIR := build/$(PRESET)
JOBS ?= $(shell nproc)

.PHONY: deps configure build demo test test-asan bench format clean

deps:
	bash scripts/install-deps.sh

configure:
	cmake --preset $(PRESET) >/dev/null

build: configure
	cmake --build --preset $(PRESET) -j $(JOBS)

demo: build
	$(BUILD_DIR)/apps/parallax/parallax demo

test: build
	ctest --preset $(PRESET) -j $(JOBS)

# The untrusted-input suites (image and PTM decoders, importers) under ASan + UBSan.
test-asan:
	$(MAKE) test PRESET=asan

bench: build
	scripts/run-benchmarks.sh $(BUILD_DIR)

format:
	find libs apps tests -name '*.cpp' -o -name '*.h' | xargs clang-format -i

clean:
	rm -rf build out
