# Penumbra: `make render` and `make test` work on a fresh Debian 12 machine (README).
# Both install what is missing (Debian packages with apt-get, Python packages into .venv),
# build the C++ libraries and the Python module, then render the example or run every test.

SHELL := /bin/bash
PYTHON ?= python3.11
VENV := .venv
VPY := $(VENV)/bin/python
BUILD_DIR := build/python
EXAMPLE_IMAGE := examples/images/cornell.png

DEBIAN_PACKAGES := build-essential cmake ninja-build pkg-config git \
	python3.11 python3.11-venv python3.11-dev \
	libembree-dev libosd-dev libopencolorio-dev libopenimageio-dev libtbb-dev \
	libopencv-core-dev openimageio-tools opencolorio-tools libgtest-dev
PYTHON_PACKAGES := usd-core==26.11 "numpy>=1.26" "pybind11>=2.12" "scikit-build-core>=0.10" "pytest>=8" "atheris>=2.3"

SUDO := $(shell [ "$$(id -u)" = 0 ] || echo sudo)

.PHONY: all deps venv build render test test-cpp test-python fuzz sanitize bench clean

all: build

## Debian packages, installed only when some are missing.
deps:
	@missing=$$(for p in $(DEBIAN_PACKAGES); do \
		dpkg-query -W -f='$${Status}' $$p 2>/dev/null | grep -q "install ok installed" || echo $$p; done); \
	if [ -n "$$missing" ]; then \
		echo "Installing Debian packages:" $$missing; \
		$(SUDO) apt-get update && \
		DEBIAN_FRONTEND=noninteractive $(SUDO) apt-get install -y --no-install-recommends $$missing; \
	fi

$(VENV)/.installed: Makefile | deps
	$(PYTHON) -m venv $(VENV)
	$(VPY) -m pip install --quiet --upgrade pip
	$(VPY) -m pip install --quiet $(PYTHON_PACKAGES)
	touch $@

venv: deps $(VENV)/.installed

## Builds the C++ libraries, tests and the module, and installs `penumbra` (editable) in .venv.
build: venv
	$(VPY) -m pip install --quiet --no-build-isolation --no-deps -e . \
		--config-settings=cmake.define.pybind11_DIR=$$($(VPY) -m pybind11 --cmakedir)

render: build
	mkdir -p $(dir $(EXAMPLE_IMAGE))
	$(VENV)/bin/penumbra-record --samples 64 examples/cornell.usda $(EXAMPLE_IMAGE)

test: build test-cpp test-python
	@# A fixed seed keeps the short run in `make test` reproducible; `make fuzz` explores anew.
	$(VPY) tests/fuzz/fuzz_scene.py -runs=300 -timeout=30 -seed=1

test-cpp:
	ctest --test-dir $(BUILD_DIR) --output-on-failure

test-python:
	$(VPY) -m pytest -q tests/python

## Longer fuzzing of the scene delegate (tests/fuzz/fuzz_scene.py); findings land in ./crash-*.
fuzz: build
	$(VPY) tests/fuzz/fuzz_scene.py -max_total_time=600 -timeout=30

## ASan + UBSan: the C++ libraries, tests and module built with both sanitizers in their own
## directory, then the C++ tests and the Python tests run under them (README, "Sanitizers").
## Python itself is not instrumented: libasan is preloaded into it (with libstdc++, which the
## interpreter does not link: ASan must find the real __cxa_throw when it starts) and its leaks
## are not reported (LeakSanitizer would list the interpreter's own allocations at exit).
## --capture=sys leaves file descriptor 2 alone, so that a sanitizer's report is seen.
SANITIZE_DIR := build/sanitize
SANITIZERS := -fsanitize=address,undefined -fno-sanitize-recover=all -fno-omit-frame-pointer
## new_delete_type_mismatch=0: OpenImageIO 2.4's TextureSystem::destroy deletes its
## implementation through the base class, whose destructor is not virtual (sized delete of 1
## byte for a 184-byte object); ASan has no per-library suppression for this check.
ASAN_COMMON := new_delete_type_mismatch=0
SANITIZER_OPTIONS := UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
## Timing assertions are meaningless in an instrumented build (several times slower).
SANITIZE_SKIP_CPP := SpectrumUpsampling.TableBuildsQuickly
SANITIZE_SKIP_PYTHON := test_signal_stops_a_billion_sample_render_within_a_second

sanitize: venv
	cmake -S . -B $(SANITIZE_DIR) -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
		-DCMAKE_CXX_FLAGS="$(SANITIZERS)" -DCMAKE_EXE_LINKER_FLAGS="$(SANITIZERS)" \
		-DCMAKE_SHARED_LINKER_FLAGS="$(SANITIZERS)" -DCMAKE_MODULE_LINKER_FLAGS="$(SANITIZERS)" \
		-DPython_EXECUTABLE=$(CURDIR)/$(VPY) -Dpybind11_DIR=$$($(VPY) -m pybind11 --cmakedir)
	cmake --build $(SANITIZE_DIR)
	$(SANITIZER_OPTIONS) ASAN_OPTIONS=$(ASAN_COMMON):detect_leaks=1 \
		ctest --test-dir $(SANITIZE_DIR) --output-on-failure -E '$(SANITIZE_SKIP_CPP)'
	$(VPY) tests/sanitize/python_env.py $(SANITIZE_DIR)
	$(SANITIZER_OPTIONS) ASAN_OPTIONS=$(ASAN_COMMON):detect_leaks=0 \
		LD_PRELOAD="$$(gcc -print-file-name=libasan.so) $$(gcc -print-file-name=libstdc++.so)" \
		$(SANITIZE_DIR)/venv/bin/python -m pytest -q -p no:cacheprovider --capture=sys \
		tests/python -k 'not $(SANITIZE_SKIP_PYTHON)'

bench: build
	$(VPY) bench/run.py cornell.usda dof.usda motion.usda glass.usda instances.usda
	$(VPY) bench/quality.py
	$(VPY) bench/instances.py --instances 100000
	$(VPY) bench/instances.py --instances 1000000
	$(VPY) bench/texture_memory.py --size 16384

clean:
	rm -rf build $(VENV)
