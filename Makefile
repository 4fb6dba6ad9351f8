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
	libopencv-core-dev openimageio-tools opencolorio-tools libgtest-dev \
	libopenvdb-dev libnanovdb-dev libboost-dev
PYTHON_PACKAGES := usd-core==26.11 "numpy>=1.26" "pybind11>=2.12" "scikit-build-core>=0.10" "pytest>=8" "atheris>=2.3" \
	"materialx>=1.39" "pyoidn>=2.3" "dask[distributed]==2026.8.0"

SUDO := $(shell [ "$$(id -u)" = 0 ] || echo sudo)

.PHONY: all deps venv build render test test-cpp test-python fuzz sanitize bench farm-demo clean

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

## A Dask scheduler and two workers on loopback render examples/turntable.usda into
## build/farm-demo/, then stop.
FARM_DEMO_DIR := build/farm-demo
farm-demo: build
	@rm -rf $(FARM_DEMO_DIR) && mkdir -p $(FARM_DEMO_DIR)
	@set -e; dask=$(VENV)/bin/dask; file=$(FARM_DEMO_DIR)/scheduler.json; pids=; \
	trap 'kill $$pids 2>/dev/null; wait $$pids 2>/dev/null || true' EXIT; \
	$$dask scheduler --host 127.0.0.1 --port 0 --no-dashboard --scheduler-file $$file \
		2> $(FARM_DEMO_DIR)/scheduler.log & pids="$$pids $$!"; \
	for n in 1 2; do \
		$$dask worker --scheduler-file $$file --host 127.0.0.1 --nthreads 1 --no-dashboard \
			--name demo-$$n 2> $(FARM_DEMO_DIR)/worker-$$n.log & pids="$$pids $$!"; \
	done; \
	for i in $$(seq 100); do [ -s $$file ] && break; sleep 0.1; done; \
	address=$$($(VPY) -c 'import json, sys; print(json.load(open(sys.argv[1]))["address"])' $$file); \
	echo "Scheduler at $$address, two workers (logs in $(FARM_DEMO_DIR))"; \
	$(VENV)/bin/penumbra-record examples/turntable.usda $(FARM_DEMO_DIR)/turntable.###.png \
		-f 1:24 -w 240 -spp 16 --scheduler $$address --threads $$(( ($$(nproc) + 1) / 2 ))

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
## Open Image Denoise loads TBB's libtbbbind with RTLD_DEEPBIND, which ASan cannot run.
SANITIZE_PYTEST_FILTER := not denoise

sanitize: venv
	cmake -S . -B $(SANITIZE_DIR) -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
		-DCMAKE_CXX_FLAGS="$(SANITIZERS)" -DCMAKE_EXE_LINKER_FLAGS="$(SANITIZERS)" \
		-DCMAKE_SHARED_LINKER_FLAGS="$(SANITIZERS)" -DCMAKE_MODULE_LINKER_FLAGS="$(SANITIZERS)" \
		-DPython_EXECUTABLE=$(CURDIR)/$(VPY) -Dpybind11_DIR=$$($(VPY) -m pybind11 --cmakedir)
	cmake --build $(SANITIZE_DIR)
	$(SANITIZER_OPTIONS) ASAN_OPTIONS=$(ASAN_COMMON):detect_leaks=1 \
		ctest --test-dir $(SANITIZE_DIR) --output-on-failure
	$(VPY) tests/sanitize/python_env.py $(SANITIZE_DIR)
	$(SANITIZER_OPTIONS) ASAN_OPTIONS=$(ASAN_COMMON):detect_leaks=0 \
		LD_PRELOAD="$$(gcc -print-file-name=libasan.so) $$(gcc -print-file-name=libstdc++.so)" \
		$(SANITIZE_DIR)/venv/bin/python -m pytest -q -p no:cacheprovider --capture=sys \
		tests/python -k '$(SANITIZE_PYTEST_FILTER)'

bench: build
	$(VPY) bench/run.py cornell.usda dof.usda motion.usda glass.usda instances.usda
	$(VPY) bench/quality.py
	$(VPY) bench/camera_noise.py
	$(VPY) bench/fingerprint.py
	$(VPY) bench/denoise.py
	$(VPY) bench/instances.py --instances 100000
	$(VPY) bench/instances.py --instances 1000000
	$(VPY) bench/groom.py
	$(VPY) bench/points_scale.py
	$(VPY) bench/volume.py
	$(VPY) bench/sync.py
	$(VPY) bench/sprim_sync.py
	$(VPY) bench/texture_memory.py --size 16384
	$(VPY) bench/latency.py

clean:
	rm -rf build $(VENV)
