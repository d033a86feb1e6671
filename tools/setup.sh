#!/usr/bin/env bash
# Installs every Debian 12 package the project needs (idempotent) and raises the
# socket receive buffers so that full-size stereo messages are not dropped.
# Run as root (or with sudo available). Safe to run again: it installs only what is missing.
set -euo pipefail

PACKAGES=(
  build-essential cmake pkg-config git
  liblcm-dev liblcm-bin liblcm-java
  libeigen3-dev libopencv-dev libyaml-dev
  libvulkan-dev mesa-vulkan-drivers vulkan-tools
  glslang-tools glslang-dev
  libaravis-dev libusb-1.0-0-dev aravis-tools-cli
  libgtest-dev googletest
  clang libclang-rt-14-dev
  default-jdk-headless libjchart2d-java
  iproute2 procps nftables
  opencv-doc
  libcpp-httplib-dev nlohmann-json3-dev libjs-three libjs-chart.js
  chromium chromium-driver python3-selenium fonts-dejavu-core
  libopen3d-dev
  # OpenCV's LAPACK (the calibrations' Levenberg-Marquardt and SVDs) on OpenBLAS instead of the reference BLAS:
  # the same results, a stereo calibration of 28 views in a third of the time. Serial: the processes parallelise
  # themselves, and a threaded BLAS inside them would compete with their own threads.
  libopenblas0-serial
)

SUDO=""
if [ "$(id -u)" -ne 0 ]; then
  if command -v sudo >/dev/null 2>&1; then SUDO="sudo"; else
    echo "setup: not root and no sudo; cannot install packages" >&2
  fi
fi

missing=()
for p in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ "${#missing[@]}" -gt 0 ]; then
  echo "setup: installing ${#missing[@]} package(s): ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  $SUDO apt-get update -qq
  $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
else
  echo "setup: all ${#PACKAGES[@]} packages already installed"
fi

# Large LCM messages (a 1360x1024 stereo pair is 2.8 MB) are fragmented over UDP; the kernel's
# default receive buffer (208 KiB) drops them. LCM asks for a bigger one but is capped by rmem_max.
WANT_RMEM=$((32 * 1024 * 1024))
for key in net.core.rmem_max net.core.rmem_default; do
  cur=$(sysctl -n "$key" 2>/dev/null || echo 0)
  if [ "$cur" -lt "$WANT_RMEM" ]; then
    if $SUDO sysctl -q -w "$key=$WANT_RMEM" >/dev/null 2>&1; then
      echo "setup: raised $key from $cur to $WANT_RMEM"
    else
      echo "setup: WARNING: cannot raise $key (now $cur); large LCM messages over UDP may be dropped." >&2
      echo "setup:          run as root: sysctl -w $key=$WANT_RMEM" >&2
    fi
  fi
done
