#!/usr/bin/env bash
# Builds bench/gpu_blend_bench with one g++ command, for a GPU machine that has g++, libEGL and
# libGLESv2 and nothing of the project's Debian dependencies: no CMake, no OpenCV, OpenEXR,
# yaml-cpp, spdlog, CLI11 or OpenSSL.
#
#   bench/gpu_standalone.sh INCLUDE_DIR LIB_DIR OUT_DIR
#
# INCLUDE_DIR holds the headers: EGL/, GLES2/, GLES3/, KHR/ (Khronos), Eigen/ or eigen3/Eigen/
# (Eigen 3.4), nlohmann/ (json_fwd.hpp, named by the bake format's header; header-only), Imath/
# (half.h: the half-float conversions, used without Imath's library). On a
# Debian machine /usr/include holds them all. LIB_DIR holds libEGL.so.1 and libGLESv2.so.2
# (linked by path; the program finds them there at run time). OUT_DIR receives gpu_blend_bench,
# which finds the shaders in this checkout's shaders/ (or $SKYLIT_SHADER_DIR).
set -euo pipefail

if [ $# -ne 3 ]; then
  echo "usage: $0 INCLUDE_DIR LIB_DIR OUT_DIR" >&2
  exit 2
fi
include_dir=$(cd "$1" && pwd)
lib_dir=$(cd "$2" && pwd)
mkdir -p "$3"
out_dir=$(cd "$3" && pwd)
repo=$(cd "$(dirname "$0")/.." && pwd)

missing=0
for header in EGL/egl.h GLES2/gl2ext.h GLES3/gl31.h KHR/khrplatform.h nlohmann/json_fwd.hpp Imath/half.h; do
  if [ ! -f "$include_dir/$header" ]; then
    echo "$0: $include_dir/$header is missing" >&2
    missing=1
  fi
done
if [ -f "$include_dir/Eigen/Core" ]; then
  eigen_dir=$include_dir
elif [ -f "$include_dir/eigen3/Eigen/Core" ]; then
  eigen_dir=$include_dir/eigen3
else
  echo "$0: Eigen is missing: neither $include_dir/Eigen/Core nor $include_dir/eigen3/Eigen/Core" >&2
  missing=1
fi
for library in libEGL.so.1 libGLESv2.so.2; do
  if [ ! -e "$lib_dir/$library" ]; then
    echo "$0: $lib_dir/$library is missing" >&2
    missing=1
  fi
done
[ "$missing" -eq 0 ] || exit 1

set -x
# src/gpu's sources named one by one: window_context.cpp needs GLFW, which this build does without.
g++ -std=c++20 -O2 -pthread \
  -I"$repo/src/base/include" -I"$repo/src/geom/include" -I"$repo/src/bake_format/include" \
  -I"$repo/src/gpu/include" -I"$repo/src/blend/include" -I"$include_dir" -I"$eigen_dir" \
  -DIMATH_HALF_NO_LOOKUP_TABLE -DSKYLIT_SOURCE_SHADER_DIR="\"$repo/shaders\"" -DSKYLIT_INSTALL_SHADER_DIR="\"/usr/local/share/skylit/shaders\"" \
  "$repo/bench/gpu_blend_bench.cpp" "$repo/bench/gpu_standalone_files.cpp" \
  "$repo/src/blend/src/gpu_blend.cpp" "$repo/src/blend/src/cpu_blend.cpp" "$repo/src/blend/src/kernel.cpp" \
  "$repo/src/blend/src/half.cpp" "$repo/src/blend/src/workers.cpp" "$repo/src/blend/src/eac.cpp" \
  "$repo/src/gpu/src/egl_context.cpp" "$repo/src/gpu/src/gl.cpp" "$repo/src/gpu/src/shader.cpp" \
  "$repo/src/base/src/error.cpp" \
  "$lib_dir/libEGL.so.1" "$lib_dir/libGLESv2.so.2" -Wl,-rpath,"$lib_dir" \
  -o "$out_dir/gpu_blend_bench"
