#!/usr/bin/env bash
# Packs what the GPU checks need for a machine that has an NVIDIA driver and nothing of the
# project's Debian dependencies (bench/device/run.sh runs them there):
#
#   bench/device/pack.sh BUILD_DIR [OUT_DIR]      (OUT_DIR defaults to .device in this checkout)
#
# OUT_DIR receives bin/ (the GPU benchmarks and the test programs that open an OpenGL ES context,
# from BUILD_DIR, a Release build with benchmarks) and libs.tar.xz: every shared library they load,
# this machine's copies, except glibc's and the GL dispatch libraries (the other machine's driver
# provides those; glvnd's packages travel in .gl, see /work/.library/device/README.md).
# OpenCV's image codecs link GDAL and GDCM for formats skylit never reads; those two are replaced
# by stub libraries with the same sonames whose functions return 0 (no dataset, no image: OpenCV
# registers GDAL's drivers at its first imread and then finds no GDAL or DICOM file), which keeps
# the carry small (GDAL alone pulls 140 MB of libraries).
set -euo pipefail
if [ $# -lt 1 ] || [ $# -gt 2 ]; then
  echo "usage: $0 BUILD_DIR [OUT_DIR]" >&2
  exit 2
fi
build=$(cd "$1" && pwd)
repo=$(cd "$(dirname "$0")/../.." && pwd)
out=${2:-$repo/.device}
programs=(gpu_blend_bench compose_bench test_gpu test_baker test_blend test_render test_compose test_shade)
stubbed=(libgdal.so.32 libgdcmMSFF.so.3.0 libgdcmDSED.so.3.0)
system_only='^(libc\.so|libm\.so|libpthread|libdl\.so|ld-linux|librt\.so|libEGL|libGLES|libGLdispatch|libGL\.so|libGLX|libOpenGL)'

installed=$(ldconfig -p)
rm -rf "$out" && mkdir -p "$out/bin" "$out/stage/lib" "$out/stage/fallback"
for program in "${programs[@]}"; do
  [ -x "$build/bin/$program" ] || { echo "$0: $build/bin/$program is missing: build it first" >&2; exit 1; }
  cp "$build/bin/$program" "$out/bin/"
done

# The NEEDED closure, stopping at the stubbed libraries.
declare -A seen=()
queue=("${programs[@]/#/$out/bin/}")
while [ ${#queue[@]} -gt 0 ]; do
  file=${queue[-1]}; unset 'queue[-1]'
  for name in $(readelf -d "$file" | sed -n 's/.*NEEDED.*\[\(.*\)\]/\1/p'); do
    [[ $name =~ $system_only ]] && continue
    [ -n "${seen[$name]:-}" ] && continue
    seen[$name]=1
    [[ " ${stubbed[*]} " == *" $name "* ]] && continue
    path=$(echo "$installed" | awk -v n="$name" '$1 == n && /x86-64/ && !found {print $NF; found = 1}')
    [ -n "$path" ] || { echo "$0: $name (needed by $file) is not installed here" >&2; exit 1; }
    # libstdc++ and libgcc_s: the other machine's own are newer and its driver may need them.
    case $name in libstdc++.so.6|libgcc_s.so.1) dest=fallback ;; *) dest=lib ;; esac
    cp -L "$path" "$out/stage/$dest/$name"
    queue+=("$path")
  done
done

# Stubs: every function of a stubbed library that a carried library imports.
for name in "${stubbed[@]}"; do
  real=$(echo "$installed" | awk -v n="$name" '$1 == n && /x86-64/ && !found {print $NF; found = 1}')
  defined=$(nm -D --defined-only "$real" | awk '$2 ~ /[TW]/ {print $3}' | sort -u)
  imported=$(for f in "$out"/stage/lib/*; do nm -D --undefined-only "$f" | awk '{print $2}'; done | sed 's/@.*//' | sort -u)
  {
    index=0
    for symbol in $(comm -12 <(echo "$defined") <(echo "$imported")); do
      echo "long stub_$index(void) __asm__(\"$symbol\"); long stub_$index(void) { return 0; }"
      index=$((index + 1))
    done
  } > "$out/stub.c"
  gcc -shared -fPIC -O1 -Wl,-soname,"$name" -o "$out/stage/lib/$name" "$out/stub.c"
done
rm -f "$out/stub.c"
# The test programs name the checkout and build folder they came from; run.sh links them there.
printf 'source_dir=%q\nbinary_dir=%q\n' "$repo" "$build" > "$out/paths"
tar -C "$out/stage" -cf - lib fallback | xz -6 -T2 > "$out/libs.tar.xz"
rm -rf "$out/stage"
du -sh "$out"/* | sed "s|$out/||"
