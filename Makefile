# Tandem: the two commands of the README, and the steps they are made of.
#   make demo   install what is missing, configure, build, run the default scene
#   make test   the same set-up, then the whole test suite (release build, then ASan + UBSan)
BUILD      ?= build
ASAN_BUILD ?= build-asan
JOBS       ?= $(shell nproc 2>/dev/null || echo 2)
DEMO_OUT   ?= out/demo
CMAKE_FLAGS ?=
ifeq ($(CI),true)
CMAKE_FLAGS += -DTND_WERROR=ON
endif

.PHONY: all deps configure build build-asan demo test test-release test-asan install fuzz clean

all: build

deps:
	@scripts/install-deps.sh

configure: deps
	cmake -S . -B $(BUILD) -DCMAKE_BUILD_TYPE=Release $(CMAKE_FLAGS)

build: configure
	cmake --build $(BUILD) -j $(JOBS)

build-asan: deps
	cmake -S . -B $(ASAN_BUILD) -DCMAKE_BUILD_TYPE=Debug -DTND_SANITIZE=ON $(CMAKE_FLAGS)
	cmake --build $(ASAN_BUILD) -j $(JOBS)

demo: build
	$(BUILD)/tandem info
	$(BUILD)/tandem render --frontend vk --scene data/scenes/cornell.gltf --frames 30 --size 640x360 \
		--capture --out $(DEMO_OUT)
	@echo
	@echo "demo: pictures in $(DEMO_OUT)/: frame_NNNN.png (display), frame_NNNN.exr (linear HDR after TAA),"
	@echo "demo: capture/frame_NNNN.exr (the whole contract; try: exrheader $(DEMO_OUT)/capture/frame_0000.exr)"
	@echo "demo: (Vulkan ray-tracing front-end (lavapipe without a GPU), A-SVGF back-end, TAA, auto exposure and ACES tone mapping on Vulkan; run.json and timings.json beside them)"

test-release: build
	scripts/run-tests.sh $(BUILD)

# Every test again under AddressSanitizer + UndefinedBehaviorSanitizer (GPU tests included:
# lavapipe runs clean under ASan, leak checking on).
test-asan: build-asan
	scripts/run-tests.sh $(ASAN_BUILD)

# Both builds are made first, then every suite runs in both; one closing line counts them all;
# then every fuzz target runs for 30 seconds (a smoke run: the regression inputs run in the
# suite; long runs with make fuzz), as many at once as there are cores (each target is one
# process, so each gets its full time).
test: build build-asan
	scripts/run-tests.sh $(BUILD) $(ASAN_BUILD)
	$(MAKE) fuzz FUZZ_SECONDS=30 FUZZ_JOBS=$(JOBS)

# The readers under libFuzzer (clang; tests/fuzz/): FUZZ_SECONDS per target, FUZZ_TARGETS to
# pick some, FUZZ_JOBS targets at once (a long run: make fuzz FUZZ_SECONDS=3600 FUZZ_JOBS=5). Its corpus grows in $(FUZZ_BUILD)/corpus; what it finds lands in artifacts/.
FUZZ_BUILD   ?= build-fuzz
FUZZ_SECONDS ?= 60
FUZZ_TARGETS ?=
fuzz: build
	CC=clang cmake -S . -B $(FUZZ_BUILD) -DTND_FUZZ=ON -DTND_WERROR=OFF \
		-DCMAKE_BUILD_TYPE=RelWithDebInfo
	cmake --build $(FUZZ_BUILD) -j $(JOBS)
	scripts/fuzz.sh $(FUZZ_BUILD) $(BUILD)/tandem $(FUZZ_SECONDS) $(FUZZ_TARGETS)

# libtandem (shared and static), its headers, pkg-config file and CMake package, and the
# tandem command, under PREFIX (default /usr/local): make install PREFIX=$$HOME/.local
PREFIX ?= /usr/local
install: build
	cmake --install $(BUILD) --prefix $(PREFIX)

clean:
	rm -rf $(BUILD) $(ASAN_BUILD) $(FUZZ_BUILD)
