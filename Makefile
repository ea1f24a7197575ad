# The two commands a newcomer runs: `make demo` and `make test`.
# Both install what they need from Debian packages first (idempotent).

PRESET ?= $(if $(CI),ci,release)
BUILD  := build
JOBS   ?= $(shell nproc)
DEMO_OUT ?= $(BUILD)/demo

.PHONY: all deps configure build test demo bench clean

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
# camera, and shades every plane under it on the CPU (the live compositor joins later).
demo: build
	$(BUILD)/bin/skylit-bake config/sample_site.yaml -o $(DEMO_OUT)/bake --force
	$(BUILD)/bin/skylit-bake verify $(DEMO_OUT)/bake
	$(BUILD)/bin/skylit-sky --calib config/sky_camera.yaml --equirect data/hdri/park.exr -o $(DEMO_OUT)/sky/park.exr
	$(BUILD)/bin/skylit-shade --bake $(DEMO_OUT)/bake --sky $(DEMO_OUT)/sky/park.exr \
	  --sky-calib config/sky_camera.yaml -o $(DEMO_OUT)/shade
	@echo "demo: bake and previews in $(DEMO_OUT)/bake (open $(DEMO_OUT)/bake/preview/*.png);"
	@echo "      shadow ratios under the park sky in $(DEMO_OUT)/shade (*.png, sky_overlay.png, sky.json)"

bench: build
	bash bench/run_bake_bench.sh

clean:
	rm -rf $(BUILD)
