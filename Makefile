# Squall — the two commands of the README:
#   make demo   install missing Debian packages, build (Release), render the default scene to MP4
#   make test   install missing packages, build and run the whole suite (Release, then ASan+UBSan)
JOBS ?= $(shell nproc)
BUILD ?= build/release
ASAN_BUILD ?= build/asan
DEMO_OUT ?= out/demo.mp4

.PHONY: all deps build demo test test-release test-asan bench clean

all: build

deps:
	@bash scripts/install-deps.sh

build: deps
	@cmake -S . -B $(BUILD) -DCMAKE_BUILD_TYPE=Release -DSQ_WERROR=ON >/dev/null
	@cmake --build $(BUILD) -j$(JOBS)

demo: build
	@mkdir -p $(dir $(DEMO_OUT))
	@$(BUILD)/squall render -o $(DEMO_OUT) --overwrite
	@echo "demo video: $(abspath $(DEMO_OUT))"

test-release: build
	@cd $(BUILD) && ctest --output-on-failure -j$(JOBS)

test-asan: deps
	@cmake -S . -B $(ASAN_BUILD) -DCMAKE_BUILD_TYPE=RelWithDebInfo -DSQ_SANITIZE=ON -DSQ_WERROR=ON >/dev/null
	@cmake --build $(ASAN_BUILD) -j$(JOBS)
	@cd $(ASAN_BUILD) && ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1 \
	    ctest --output-on-failure -j$(JOBS) -LE perf

test: test-release test-asan

clean:
	rm -rf build
