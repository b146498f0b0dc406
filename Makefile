# libvis — the two commands a new user types: `make run` and `make test`.
# Both install what is missing (Debian packages, via apt-get), configure, build and go.

BUILD      ?= build
BUILD_ASAN ?= build-asan
BUILD_TSAN ?= build-tsan
JOBS       ?= $(shell nproc 2>/dev/null || echo 2)
CMAKE_ARGS ?=
VIS        := $(BUILD)/tools/vis

# Debian packages: the compiler and build tools, then every optional feature's library.
DEB_PACKAGES := build-essential cmake pkg-config libcmocka-dev libpng-dev \
                ocl-icd-opencl-dev opencl-headers pocl-opencl-icd clinfo \
                libopenvdb-dev libboost-iostreams-dev libglfw3-dev libepoxy-dev libembree-dev gnuplot-nox clang \
                xvfb xauth libjansson-dev

.PHONY: all deps configure build run viewer test test-release test-asan test-tsan bench fuzz install-test clean

all: build

# Installs only what is missing. As root apt-get runs directly, otherwise through sudo;
# without either it says what to install and goes on (optional features then switch off).
deps:
	@missing=""; for p in $(DEB_PACKAGES); do \
	  dpkg-query -W -f='$${Status}\n' $$p 2>/dev/null | grep -q "install ok installed" || missing="$$missing $$p"; \
	done; \
	if [ -n "$$missing" ]; then \
	  echo "Installing missing Debian packages:$$missing"; \
	  if [ "$$(id -u)" = 0 ]; then SUDO=""; elif command -v sudo >/dev/null; then SUDO="sudo"; else SUDO="none"; fi; \
	  if [ "$$SUDO" = none ]; then echo "Not root and no sudo: please install:$$missing"; \
	  else $$SUDO env DEBIAN_FRONTEND=noninteractive apt-get update -qq && \
	       $$SUDO env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends $$missing </dev/null \
	       || echo "apt-get failed; continuing with what is installed"; fi; \
	fi

$(BUILD)/CMakeCache.txt: | deps
	cmake -S . -B $(BUILD) -DCMAKE_BUILD_TYPE=Release $(CMAKE_ARGS)

configure: deps
	cmake -S . -B $(BUILD) -DCMAKE_BUILD_TYPE=Release $(CMAKE_ARGS)

build: $(BUILD)/CMakeCache.txt
	cmake --build $(BUILD) -j $(JOBS)

# The main job: the default world, generated and meshed, culled along a camera path.
run: build
	$(VIS) run

# The GLFW viewer (demo/, docs/viewer.md) on the default world, or VIEWER_ARGS (e.g.
# VIEWER_ARGS="--scene ../shared/data/vox/mmmm_scene_store8.vox"). Needs a display.
VIEWER_ARGS ?=
viewer: build
	@test -x $(BUILD)/demo/vis-viewer || { echo "vis-viewer was not built (needs libglfw3-dev, libepoxy-dev, libpng-dev)"; exit 1; }
	$(BUILD)/demo/vis-viewer $(VIEWER_ARGS)

# Every test, in a release build and again under AddressSanitizer + UBSan (the viewer test
# too: vis-viewer is built with ASan and run under Xvfb, demo/lsan.supp); the threading
# tests once more under ThreadSanitizer.
test: test-release test-asan test-tsan

test-release: build
	cd $(BUILD) && ctest --output-on-failure -j $(JOBS)

test-asan: deps
	cmake -S . -B $(BUILD_ASAN) -DCMAKE_BUILD_TYPE=RelWithDebInfo -DVIS_SANITIZE=ON -DVIS_BUILD_DEMO=ON $(CMAKE_ARGS)
	cmake --build $(BUILD_ASAN) -j $(JOBS)
	cd $(BUILD_ASAN) && ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
	  VIS_TEST_SCALE=small ctest --output-on-failure -j $(JOBS)

# ThreadSanitizer on the threading tests only (tests/test_threads.c: one context from two
# threads, one scene traced through four contexts while a fifth thread edits and commits, the
# parallel_for hook; test_generators and test_mesher: worlds generated and chunks meshed on
# 1-7 threads). The rest of the suite is single-threaded and would only add minutes.
# No target_clones there: their ifunc resolvers run before TSan's runtime is up and crash.
TSAN_TESTS ?= threads generators mesher query
test-tsan: deps
	cmake -S . -B $(BUILD_TSAN) -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_C_FLAGS="-fsanitize=thread -DVIS_NO_TARGET_CLONES" \
	  -DCMAKE_EXE_LINKER_FLAGS="-fsanitize=thread" -DCMAKE_SHARED_LINKER_FLAGS="-fsanitize=thread" \
	  -DVIS_BUILD_DEMO=OFF -DVIS_BUILD_TOOLS=OFF -DVIS_WITH_OPENVDB=OFF -DVIS_WITH_OPENCL=OFF $(CMAKE_ARGS)
	cmake --build $(BUILD_TSAN) -j $(JOBS) --target $(addprefix test_,$(TSAN_TESTS))
	cd $(BUILD_TSAN) && TSAN_OPTIONS=halt_on_error=1:second_deadlock_stack=1 VIS_TEST_SCALE=small \
	  ctest --output-on-failure -j $(JOBS) -R "^($$(echo $(TSAN_TESTS) | tr ' ' '|'))\$$"

bench: build
	$(VIS) bench

clean:
	rm -rf $(BUILD) $(BUILD_ASAN) $(BUILD_TSAN) build-fuzz

# libFuzzer on the .vox importer (and exporter): clang, AddressSanitizer + UBSan, one job.
# Seeds are copied at run time from ../shared/data/vox into the git-ignored fuzz/corpus/
# (never committed: those files keep their authors' licenses, see ATTRIBUTION.md); what the
# fuzzer adds stays there for the next run. Crashes land in fuzz/ as crash-* files.
# `make fuzz FUZZ_SECONDS=1800` for a long run; docs/vox.md keeps the record.
BUILD_FUZZ   ?= build-fuzz
FUZZ_SECONDS ?= 60
# Inputs stay small (the thinned seeds are a few KB); the full-size originals are truncated
# to this when read. FUZZ_MAX_LEN=0 lets libFuzzer pick (up to 1 MiB).
FUZZ_MAX_LEN ?= 131072

fuzz: deps
	cmake -S . -B $(BUILD_FUZZ) -DCMAKE_C_COMPILER=clang -DCMAKE_BUILD_TYPE=RelWithDebInfo \
	  -DVIS_FUZZ=ON -DVIS_SANITIZE=ON -DVIS_BUILD_TESTS=OFF -DVIS_BUILD_TOOLS=OFF -DVIS_BUILD_DEMO=OFF \
	  -DVIS_WITH_OPENVDB=OFF -DVIS_WITH_OPENCL=OFF $(CMAKE_ARGS)
	cmake --build $(BUILD_FUZZ) -j $(JOBS) --target fuzz_vox fuzz_vox_seeds
	mkdir -p fuzz/corpus/vox
	if ls ../shared/data/vox/*.vox >/dev/null 2>&1; then cp -n ../shared/data/vox/*.vox fuzz/corpus/vox/ && \
	  $(BUILD_FUZZ)/fuzz/fuzz_vox_seeds fuzz/corpus/vox ../shared/data/vox/*.vox; \
	  else echo "no ../shared/data/vox seeds: fuzzing from the corpus as it is"; fi
	cd fuzz && ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1 \
	  ../$(BUILD_FUZZ)/fuzz/fuzz_vox -max_total_time=$(FUZZ_SECONDS) -max_len=$(FUZZ_MAX_LEN) -timeout=30 -print_final_stats=1 corpus/vox
