# Squall — the two commands of the README:
#   make demo   install missing Debian packages, build (Release), render the default scene to MP4
#   make test   install missing packages, build and run the whole suite (Release, then ASan+UBSan,
#               then the simulation-only build without OpenGL/FFmpeg, then every fuzz harness
#               for FUZZ_CI_SECONDS under libFuzzer + ASan+UBSan)
#   make fuzz   run every fuzz harness for FUZZ_SECONDS each (clang, libFuzzer, ASan+UBSan)
#   make install  build a portable library (no -march=native) and install it under PREFIX
JOBS ?= $(shell nproc)
BUILD ?= build/release
ASAN_BUILD ?= build/asan
FUZZ_BUILD ?= build/fuzz
NOGL_BUILD ?= build/nogl
INSTALL_BUILD ?= build/install
PREFIX ?= /usr/local
DEMO_OUT ?= out/demo.mp4
FUZZ_SECONDS ?= 300
FUZZ_CI_SECONDS ?= 10
FUZZ_CI_SEED ?= 20261127

.PHONY: all deps build demo test test-release test-asan test-nogl test-fuzz fuzz fuzz-build install bench clean

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

# intercept_tls_get_addr=0: with it, LeakSanitizer's stop-the-world tracer read a bogus dynamic-TLS
# range of the main thread after llvmpipe's modules were loaded (`DTLS 34 at 0x1377-0x1800002479`)
# and crashed ("Tracer caught signal 11") at the exit of `squall render suburb`; the leak check
# itself stays on (GCC 12's libsanitizer with glibc 2.36).
test-asan: deps
	@cmake -S . -B $(ASAN_BUILD) -DCMAKE_BUILD_TYPE=RelWithDebInfo -DSQ_SANITIZE=ON -DSQ_WERROR=ON >/dev/null
	@cmake --build $(ASAN_BUILD) -j$(JOBS)
	@cd $(ASAN_BUILD) && ASAN_OPTIONS=detect_leaks=1:abort_on_error=1:intercept_tls_get_addr=0 \
	    UBSAN_OPTIONS=print_stacktrace=1 \
	    ctest --output-on-failure -j$(JOBS) -LE perf

# The simulation-only library: no OpenGL (EGL, libepoxy) and no FFmpeg; the tests that need them
# are not registered there (SQ_REQUIRES(gl) / "# requires: gl mp4").
test-nogl: deps
	@cmake -S . -B $(NOGL_BUILD) -DCMAKE_BUILD_TYPE=Release -DSQ_WERROR=ON -DSQ_WITH_GL=OFF -DSQ_WITH_MP4=OFF >/dev/null
	@cmake --build $(NOGL_BUILD) -j$(JOBS)
	@cd $(NOGL_BUILD) && ctest --output-on-failure -j$(JOBS) -LE perf

# A portable install (SQ_NATIVE=OFF: no -march=native in the installed library): docs/api.md.
install: deps
	@cmake -S . -B $(INSTALL_BUILD) -DCMAKE_BUILD_TYPE=Release -DSQ_NATIVE=OFF -DSQ_BUILD_TESTS=OFF -DCMAKE_INSTALL_PREFIX=$(PREFIX) >/dev/null
	@cmake --build $(INSTALL_BUILD) -j$(JOBS)
	@cmake --install $(INSTALL_BUILD)

# The fuzz harnesses (tests/fuzz) with libFuzzer: clang, the whole library instrumented (no
# -Werror here: warnings are enforced by the gcc builds; clang-only ones must not stop fuzzing).
fuzz-build: deps
	@CC=clang cmake -S . -B $(FUZZ_BUILD) -DCMAKE_BUILD_TYPE=RelWithDebInfo -DSQ_FUZZ=ON -DSQ_WERROR=OFF >/dev/null
	@cmake --build $(FUZZ_BUILD) -j$(JOBS) --target fuzz_all

# Each harness for a short budget (new inputs stay in $(FUZZ_BUILD)/fuzz-work, never the repo).
test-fuzz: fuzz-build
	@cd $(FUZZ_BUILD) && SQ_FUZZ_SECONDS=$(FUZZ_CI_SECONDS) SQ_FUZZ_SEED=$(FUZZ_CI_SEED) ctest --output-on-failure -L fuzz

fuzz: fuzz-build
	@cd $(FUZZ_BUILD) && SQ_FUZZ_SECONDS=$(FUZZ_SECONDS) ctest --output-on-failure -L fuzz
	@echo "fuzz log: $(abspath $(FUZZ_BUILD))/fuzz-work/fuzz-log.tsv"

test: test-release test-asan test-nogl test-fuzz

clean:
	rm -rf build
