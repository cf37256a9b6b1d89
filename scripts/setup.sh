#!/usr/bin/env bash
# Installs what a fresh Debian 12 machine lacks to build and test ExploreMaps.
# Idempotent and quick when everything is already there. The Embree 4 library
# itself is fetched by the builder's build script (see builder/build.rs).
set -euo pipefail

SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi

# Debian packages: libclang for embree4-sys's bindgen; pkg-config to find a
# system Embree; python3-pip to fetch the Embree wheel when pip is missing;
# ffmpeg (libx264) for transition videos half the size of the built-in
# encoder's; Mesa's lavapipe (Vulkan on the CPU) for the viewer's GPU tests.
packages=(libclang1-14 libclang-common-14-dev pkg-config ffmpeg mesa-vulkan-drivers libvulkan1)
python3 -m pip --version >/dev/null 2>&1 || packages+=(python3-pip)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "setup: installing ${missing[*]}"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

command -v cargo >/dev/null || { echo "setup: cargo is missing; install Rust with rustup (https://rustup.rs), then run this again" >&2; exit 1; }
echo "setup: ready"
