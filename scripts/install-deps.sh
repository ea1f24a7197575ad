#!/usr/bin/env bash
# Installs every build and run-time dependency of skylit from Debian 12 packages.
# Idempotent: packages already present are skipped, and apt is not touched at all
# when nothing is missing.
set -euo pipefail

packages=(
  build-essential cmake ninja-build pkg-config lld
  libopencv-dev libeigen3-dev
  libegl-dev libgles-dev libegl-mesa0 libgl1-mesa-dri libglfw3-dev
  libembree-dev libtinygltf-dev libdraco-dev libtinyobjloader-dev libceres-dev
  libyaml-cpp-dev nlohmann-json3-dev libspdlog-dev libcli11-dev
  libopenexr-dev libgtest-dev libgmock-dev libbenchmark-dev
  libapriltag-dev libhidapi-dev libcamera-dev
  libssl-dev glslang-tools libexif-dev libcpp-httplib-dev
  libmosquitto-dev mosquitto openssl prometheus
  xvfb xauth ffmpeg systemd
  chromium chromium-driver python3-selenium python3-pil
  clang libclang-rt-dev
  dpkg-dev file lintian help2man
  slurm-wlm munge
)

missing=()
for p in "${packages[@]}"; do
  status=$(dpkg-query -W -f='${Status}' "$p" 2>/dev/null || true)
  [[ "$status" == "install ok installed" ]] || missing+=("$p")
done

if [[ ${#missing[@]} -eq 0 ]]; then
  echo "install-deps: all ${#packages[@]} packages present"
  exit 0
fi

echo "install-deps: installing ${missing[*]}"
sudo_cmd=()
if [[ $(id -u) -ne 0 ]]; then
  command -v sudo >/dev/null || { echo "install-deps: run as root or install sudo" >&2; exit 1; }
  sudo_cmd=(sudo)
fi
export DEBIAN_FRONTEND=noninteractive
"${sudo_cmd[@]}" apt-get update -qq
"${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}"
