#!/usr/bin/env bash
# Installs Parallax's build, test and benchmark dependencies from Debian 12 packages.
# Idempotent and quiet: packages already present are left alone. Must run as root (or via sudo).
set -euo pipefail

packages=(
    # build, tests, benchmarks
    cmake ninja-build g++ make pkg-config libgtest-dev libgmock-dev libbenchmark-dev
    # libraries the toolkit links
    libglm-dev libtbb-dev libassimp-dev libpng-dev libjpeg-dev libturbojpeg0-dev libzstd-dev
    zlib1g-dev
    libcli11-dev nlohmann-json3-dev libfmt-dev
    # WebSocket transport of remote sessions (Boost.Beast and Asio, header-only)
    libboost1.81-dev
    # OpenGL peer (Mesa llvmpipe through EGL, no display needed)
    libegl-dev libgl-dev libegl-mesa0 libgl1-mesa-dri mesa-common-dev
    # codec peers used by benchmarks only
    libwebp-dev libjxl-dev optipng
    # a real web server for the HTTP streaming tests (Range requests, limit_rate)
    nginx-light
    # fuzzing and sanitizers
    clang
    # the portability test (disassembles parallax; objdump comes with binutils)
    python3 binutils
    # the browser test (tests/browser): a real browser, driven headless
    chromium
)

missing=()
for p in "${packages[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done

SUDO=""
if [ "$(id -u)" -ne 0 ]; then
    SUDO="sudo"
fi
export DEBIAN_FRONTEND=noninteractive
# Node and npm for the browser test, from Debian only when no npm is on PATH (Debian's npm
# conflicts with a nodejs from elsewhere).
if ! command -v npm >/dev/null 2>&1; then
    missing+=(nodejs npm)
fi
if [ "${#missing[@]}" -ne 0 ]; then
    $SUDO apt-get update -qq
    $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

# playwright-core as pinned in tests/browser/package-lock.json (it never downloads a browser: the
# test launches /usr/bin/chromium). Reinstalled only when the lock file changed.
browser="$(cd "$(dirname "$0")/.." && pwd)/tests/browser"
if ! cmp -s "$browser/package-lock.json" "$browser/node_modules/.plx-package-lock.json"; then
    (cd "$browser" && PLAYWRIGHT_SKIP_BROWSER_DOWNLOAD=1 npm ci --no-audit --no-fund \
        --loglevel=error >/dev/null)
    cp "$browser/package-lock.json" "$browser/node_modules/.plx-package-lock.json"
fi
