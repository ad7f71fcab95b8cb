#!/usr/bin/env bash
# Installs the Debian packages odoerr needs, only those that are missing.
# Usage: scripts/deps.sh            (as root, or with sudo available)
set -euo pipefail

PACKAGES=(
  cmake ninja-build make    # build (the presets use Ninja; make for a plain `cmake -B`)
  clang-14 g++              # the host preset compiles with clang 14 (libstdc++ from g++); host-asan and host-gcc with g++
  libeigen3-dev             # core
  libcli11-dev nlohmann-json3-dev   # odoerr tool
  libboost-dev              # Boost.Math (header-only): exact chi-square quantiles
  libgtest-dev libbenchmark-dev     # tests, benchmarks
  python3 python3-matplotlib python3-numpy python3-jinja2  # figures, the report
  python3-scipy             # odoerr map import (tools/map: ndimage, cKDTree); paper_compare.py --paired
)
# Target build and emulation (the test command): bash scripts/deps.sh --target
if [ "${1:-}" = "--target" ]; then
  PACKAGES+=(gcc-arm-none-eabi libnewlib-arm-none-eabi libstdc++-arm-none-eabi-dev qemu-system-arm
            chromium   # the report's render test (headless)
            libclang-rt-14-dev)  # the fuzz preset: libFuzzer + ASan/UBSan runtimes for clang 14
fi

missing=()
for p in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  exit 0
fi

echo "odoerr: installing missing Debian packages: ${missing[*]}" >&2
SUDO=""
if [ "$(id -u)" -ne 0 ]; then
  if command -v sudo >/dev/null 2>&1; then
    SUDO="sudo"
  else
    echo "odoerr: need root (or sudo) to install: ${missing[*]}" >&2
    exit 1
  fi
fi
export DEBIAN_FRONTEND=noninteractive
# Quietly: the package manager's progress goes to a log, shown only when it fails.
log="$(mktemp -t odoerr-deps.XXXXXX)"
if ! { $SUDO apt-get update -qq && $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"; } >"$log" 2>&1; then
  echo "odoerr: installing the packages failed; the package manager said:" >&2
  tail -n 40 "$log" >&2
  rm -f "$log"
  exit 1
fi
rm -f "$log"
echo "odoerr: installed ${#missing[@]} packages" >&2
