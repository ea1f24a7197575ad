#!/usr/bin/env bash
# The GPU checks on a machine with an NVIDIA driver, from what bench/device/pack.sh packed into
# .device (and glvnd's packages in .gl): run from the checkout's root as root, results in $OUT.
#
#   bench/device/run.sh [STEP...]      (default: every step, in this order; DEVICE_TESTS=... picks
#                                       the test programs)
#
#   blend, eac, forms: the blend forms against the bandwidth floor (gpu_blend_bench): R16F and R8
#      (blend.md), EAC (eac.md), PCA untiled and tiled and cropped pages (forms.md);
#   compose: the HMD node's frame (compose_bench), the stereo frame at 2 × 1920×1080 and its
#      stages: compose.txt;
#   tests: every test program that opens an OpenGL ES context (each shader compiled, linked and run on
#      the real driver, its results checked against the CPU references): tests.log.
# Each step has its own time limit so that one that hangs leaves the others their time.
set -uo pipefail
repo=$(pwd)
out=${OUT:-/tmp/out}
mkdir -p "$out"
for f in .gl/*.deb; do dpkg -x "$f" /; done
ldconfig
export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
[ -f /usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json ] &&
  export __EGL_VENDOR_LIBRARY_FILENAMES=/usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json
mkdir -p /tmp/skylit
tar -C /tmp/skylit -xJf .device/libs.tar.xz 2>/dev/null ||
  python3 -c 'import sys, tarfile; tarfile.open(sys.argv[1]).extractall(sys.argv[2])' .device/libs.tar.xz /tmp/skylit
library_path=/tmp/skylit/lib
ldconfig -p | grep -q 'libstdc++.so.6 ' || library_path=$library_path:/tmp/skylit/fallback
ldconfig -p | grep -q 'libgcc_s.so.1 ' || library_path=$library_path:/tmp/skylit/fallback
export LD_LIBRARY_PATH=$library_path${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}
export SKYLIT_SHADER_DIR=$repo/shaders
# The test programs name the checkout and the build folder they were built from (pack.sh).
source .device/paths
for pair in "$source_dir:$repo" "$binary_dir:$repo/.device"; do
  link=${pair%%:*}
  [ -e "$link" ] || { mkdir -p "$(dirname "$link")" && ln -s "${pair#*:}" "$link"; }
done
nvidia-smi --query-gpu=name,driver_version,memory.total,clocks.max.sm,clocks.max.mem --format=csv | tee "$out/device.txt"
nproc >> "$out/device.txt"

steps=${*:-blend eac forms compose tests}
for step in $steps; do
  case $step in
    blend)
      echo "== blend: R16F and R8 against the floor" | tee "$out/blend.md"
      timeout 240 .device/bin/gpu_blend_bench --repeats 15 --batch 20 --layout packed --storage r16f,r8 \
        >> "$out/blend.md" 2>&1
      echo "gpu_blend_bench: exit $?" | tee -a "$out/blend.md" ;;
    eac)
      # EAC's layers are encoded on upload, for every plane (noise, its worst case: ~0.2 s per 512²
      # layer on two cores), so one plane per ν.
      echo "== EAC" | tee "$out/eac.md"
      timeout 120 .device/bin/gpu_blend_bench --repeats 15 --batch 20 --storage eac --layout packed --planes 1 \
        >> "$out/eac.md" 2>&1
      echo "gpu_blend_bench eac: exit $?" | tee -a "$out/eac.md" ;;
    forms)
      echo "== PCA (untiled, 64² and 32² tiles) and cropped pages" | tee "$out/forms.md"
      timeout 250 .device/bin/gpu_blend_bench --repeats 9 --batch 20 --layout packed --storage r16f,r8 \
        --frequencies 4,8 --planes 1,4 --pca 16 --pca-tiles 0,64,32 --cropped 0.43 >> "$out/forms.md" 2>&1
      echo "gpu_blend_bench forms: exit $?" | tee -a "$out/forms.md" ;;
    compose)
      echo "== compose" | tee "$out/compose.txt"
      timeout 150 .device/bin/compose_bench --benchmark_repetitions=5 --benchmark_report_aggregates_only=true \
        --benchmark_filter='BM_HmdFrame|BM_CompositeDraw|BM_CompositeStages|BM_SunShadowUpdate|BM_CompositeDrawNewSky' \
        >> "$out/compose.txt" 2>&1
      echo "compose_bench: exit $?" | tee -a "$out/compose.txt" ;;
    tests)
      echo "== tests" | tee "$out/tests.log"
      for program in ${DEVICE_TESTS:-test_gpu test_baker test_blend test_render test_compose test_shade}; do
        echo "== $program" >> "$out/tests.log"
        timeout 60 ".device/bin/$program" --gtest_brief=1 >> "$out/tests.log" 2>&1
        echo "$program: exit $?" | tee -a "$out/tests.log"
      done ;;
    *) echo "$0: unknown step '$step' (blend, eac, forms, compose, tests)" >&2; exit 2 ;;
  esac
done
