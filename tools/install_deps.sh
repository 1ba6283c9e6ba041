#!/usr/bin/env bash
# Installs the Debian 12 packages the project needs, only those missing.
set -euo pipefail

packages=(
  build-essential cmake ninja-build ccache pkg-config git
  libeigen3-dev libpcl-dev libassimp-dev libembree-dev libosmesa6-dev libopencv-dev
  libceres-dev libsqlite3-dev libgtest-dev libgmock-dev libbenchmark-dev
  nlohmann-json3-dev libcli11-dev libzip-dev zlib1g-dev libxxhash-dev libdeflate-dev libzstd-dev liblz4-dev
  libyaml-cpp-dev libpng-dev libplplot-dev plplot-driver-cairo fonts-dejavu-core chromium libjs-three sweethome3d-furniture valgrind
  python3-dev pybind11-dev python3-numpy python3-matplotlib libtorch-dev libgloo-dev
  slurm-wlm munge
  librosbag-dev libsensor-msgs-dev libvisualization-msgs-dev libtf2-msgs-dev libgeometry-msgs-dev
)

missing=()
for package in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$package" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$package")
  fi
done
if [[ ${#missing[@]} -eq 0 ]]; then
  echo "install_deps: all ${#packages[@]} packages present"
  exit 0
fi

sudo=()
if [[ $(id -u) -ne 0 ]]; then
  command -v sudo > /dev/null || { echo "install_deps: missing ${missing[*]}; run as root" >&2; exit 1; }
  sudo=(sudo)
fi
echo "install_deps: installing ${missing[*]}"
"${sudo[@]}" apt-get update -q
DEBIAN_FRONTEND=noninteractive "${sudo[@]}" apt-get install -y -q --no-install-recommends "${missing[@]}"
