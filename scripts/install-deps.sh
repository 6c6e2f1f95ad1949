#!/usr/bin/env bash
# Installs Parallax's build, test and benchmark dependencies from Debian 12 packages.
# Idempotent and quiet: packages already present are left alone. Must run as root (or via sudo).
set -euo pipefail

packages=(
    # build, tests, benchmarks
    cmake ninja-build g++ make pkg-config libgtest-dev libgmock-dev libbenchmark-dev
    # libraries the toolkit links
    libglm-dev libtbb-dev libassimp-dev libpng-dev libjpeg-dev libturbojpeg0-dev libzstd-dev
    libcli11-dev nlohmann-json3-dev libfmt-dev
    # WebSocket transport of remote sessions (Boost.Beast and Asio, header-only)
    libboost1.81-dev
    # OpenGL peer (Mesa llvmpipe through EGL, no display needed)
    libegl-dev libgl-dev libegl-mesa0 libgl1-mesa-dri mesa-common-dev
    # codec peers used by benchmarks only
    libwebp-dev libjxl-dev optipng
    # fuzzing and sanitizers
    clang
    # the portability test (disassembles parallax; objdump comes with binutils)
    python3 binutils
)

missing=()
for p in "${packages[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done

if [ "${#missing[@]}" -eq 0 ]; then
    exit 0
fi

SUDO=""
if [ "$(id -u)" -ne 0 ]; then
    SUDO="sudo"
fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
