# The two commands a newcomer runs: `make demo` and `make test`.
# Both install what they need from Debian packages first (idempotent).

PRESET ?= $(if $(CI),ci,release)
BUILD  := build
JOBS   ?= $(shell nproc)
DEMO_OUT ?= $(BUILD)/demo

.PHONY: all deps configure build test demo demo-site bench fuzz package clean

all: build

deps:
	bash scripts/install-deps.sh

configure: deps
	cmake --preset $(PRESET) -DSKYLIT_WERROR=$(if $(CI),ON,OFF)

build: configure
	cmake --build $(BUILD) -j $(JOBS)

test: build
	ctest --test-dir $(BUILD) --output-on-failure -j $(JOBS)

# Bakes the bundled sample site with its previews, renders a real HDR sky into the sample sky
# camera and shades every plane under it on the CPU; then films the site's ground with a
# synthetic HMD camera and runs the live service on it: a simulated clear day (config/demo.yaml)
# and the real park sky (config/demo_park.yaml), recorded, with a contact sheet of each run; and,
# when a display is there, the clear day once more in a window. The live configs name
# build/demo/ (their paths are relative to config/), so DEMO_OUT stays build/demo for them.
demo: build
	$(BUILD)/bin/skylit-bake config/sample_site.yaml -o $(DEMO_OUT)/bake --force
	$(BUILD)/bin/skylit-bake verify $(DEMO_OUT)/bake
	$(BUILD)/bin/skylit-sky --calib config/sky_camera.yaml --equirect data/hdri/park.exr -o $(DEMO_OUT)/sky/park.exr
	$(BUILD)/bin/skylit-shade --bake $(DEMO_OUT)/bake --sky $(DEMO_OUT)/sky/park.exr \
	  --sky-calib config/sky_camera.yaml -o $(DEMO_OUT)/shade
	$(BUILD)/bin/skylit-camera-sim --calib config/hmd_camera.yaml -o $(DEMO_OUT)/camera \
	  --frames 120 --sweep 50 --start-azimuth -120
	@echo "demo: skylit-live on a clear day (about 40 s; status on http://127.0.0.1:8080/status)"
	$(BUILD)/bin/skylit-live config/demo.yaml --headless --record $(DEMO_OUT)/live.mp4
	$(BUILD)/bin/skylit-contact-sheet $(DEMO_OUT)/live.mp4 -o $(DEMO_OUT)/contact_sheet.png --utc-offset 9
	@echo "demo: skylit-live under the real park sky (about 40 s)"
	$(BUILD)/bin/skylit-live config/demo_park.yaml --headless --record $(DEMO_OUT)/live_park.mp4
	$(BUILD)/bin/skylit-contact-sheet $(DEMO_OUT)/live_park.mp4 -o $(DEMO_OUT)/contact_sheet_park.png --grid 3x2
	@if [ -n "$$DISPLAY$$WAYLAND_DISPLAY" ]; then \
	  echo "demo: the clear day in a window (close it, or press Q, to end)"; \
	  $(BUILD)/bin/skylit-live config/demo.yaml --record $(DEMO_OUT)/live_window.mp4; \
	else echo "demo: no display: the windowed run is left out"; fi
	@echo "demo: bake and previews in $(DEMO_OUT)/bake (open $(DEMO_OUT)/bake/preview/*.png);"
	@echo "      shadow ratios under the park sky in $(DEMO_OUT)/shade (*.png, sky_overlay.png, sky.json);"
	@echo "      the live service's recordings $(DEMO_OUT)/live.mp4 and live_park.mp4 (frame logs live*.csv),"
	@echo "      their contact sheets $(DEMO_OUT)/contact_sheet.png and contact_sheet_park.png"

# A site with many visitors (docs/site.md): a mosquitto broker on a free loopback port, the sky
# node on the clear day and three HMD nodes on three camera paths, headless; their recordings, a
# contact sheet of the three side by side and the sky node's /site JSON in $(DEMO_OUT)/site.
demo-site: build
	bash scripts/demo_site.sh $(BUILD) $(DEMO_OUT)/site

# Builds the benchmarks (left out of `build`, see CMakeLists.txt) and runs the bake benchmark;
# the others are run by hand (bench/RESULTS.md names the command of each figure).
bench: build
	cmake --build $(BUILD) -j $(JOBS) --target benchmarks
	bash bench/run_bake_bench.sh

# Fuzzes every parser of outside input (docs/fuzzing.md): the harnesses in fuzz/ built with clang,
# libFuzzer, ASan and UBSan in build-fuzz/, each run FUZZ_SECONDS (default 600, the goal; 60 for a
# quick pass), FUZZ_JOBS at a time; build-fuzz/fuzz-report.md has executions/s and coverage.
# `make test` replays the seeds and every input that once crashed (fuzz/corpus) without them.
fuzz: deps
	bash scripts/fuzz.sh $(HARNESS)

# The Debian package (docs/install.md): $(BUILD)/skylit_<version>_amd64.deb, its dependencies
# found by dpkg-shlibdeps. Install it with `apt install ./$(BUILD)/skylit_*_amd64.deb`.
package: build
	cd $(BUILD) && cpack --config CPackConfig.cmake
	@ls $(BUILD)/skylit_*_amd64.deb

clean:
	rm -rf $(BUILD)
