#!/usr/bin/env bash
# Installs what a fresh Debian 12 machine lacks to build and test ExploreMaps.
# Idempotent and quick when everything is already there. The Embree 4 library
# itself is fetched by the builder's build script (see builder/build.rs).
set -euo pipefail

SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi

# Debian packages: g++ for meshoptimizer (glTF's meshopt compression);
# libclang for embree4-sys's bindgen; pkg-config to find a
# system Embree; python3-pip to fetch the Embree wheel when pip is missing;
# ffmpeg (libx264) for transition videos half the size of the built-in
# encoder's; Mesa's lavapipe (Vulkan on the CPU) for the viewer's GPU tests;
# Chromium, Xvfb, xdotool and ImageMagick for the viewer's browser and window
# tests; Node for Playwright; bc for scripts' timings.
packages=(g++ libclang1-14 libclang-common-14-dev pkg-config ffmpeg mesa-vulkan-drivers libvulkan1
          chromium xvfb xauth xdotool imagemagick bc)
python3 -m pip --version >/dev/null 2>&1 || packages+=(python3-pip)
command -v node >/dev/null 2>&1 || packages+=(nodejs)
command -v npm >/dev/null 2>&1 || packages+=(npm)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "setup: installing ${missing[*]}"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

# Slurm and munge for scripts/slurm-test.sh (a one-node cluster it starts on
# localhost, without the system's services). Installed on their own: where
# their packages cannot install, that test says SKIPPED and nothing else fails.
slurm=(slurmctld slurmd slurm-client munge)
if ! dpkg-query -W -f='${Status}\n' "${slurm[@]}" 2>/dev/null | grep -c "install ok installed" | grep -qx "${#slurm[@]}"; then
  echo "setup: installing ${slurm[*]}"
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${slurm[@]}" >/dev/null \
    || echo "setup: Slurm did not install; scripts/slurm-test.sh will be skipped"
fi

# The Kubernetes Job schema validator (PyPI), for the test of deploy/kubernetes.
k8s_dir="$(cd "$(dirname "$0")/.." && pwd)/target/k8s-validate"
if [ ! -d "$k8s_dir/kubernetes_validate" ]; then
  echo "setup: fetching kubernetes-validate 1.37.0 (the Job schema, 23 MB)"
  python3 -m pip install --quiet --disable-pip-version-check --target "$k8s_dir.part" kubernetes-validate==1.37.0
  rm -rf "$k8s_dir" && mv "$k8s_dir.part" "$k8s_dir"
fi

# Intel Open Image Denoise has no Debian package: take the libraries of the
# pyoidn wheel (pinned by hash) into target/oidn/lib, where .cargo/config.toml
# points OIDN_DIR for the `oidn` crate. Only the CPU device and TBB are kept.
oidn_dir="$(cd "$(dirname "$0")/.." && pwd)/target/oidn"
if [ ! -e "$oidn_dir/lib/libOpenImageDenoise_device_cpu.so.2.5.1" ]; then
  echo "setup: fetching Open Image Denoise 2.5.1 (the pyoidn wheel, 88 MB)"
  tmp="$(mktemp -d)"
  echo "pyoidn==2.5.1.0 --hash=sha256:32ad13368f8de1ef63001942ad05b02a00cd732d1206d97f352d3a3f606d823e" > "$tmp/requirements.txt"
  python3 -m pip download --quiet --no-deps --only-binary=:all: --require-hashes \
    --python-version 3.11 --platform manylinux2014_x86_64 -d "$tmp" -r "$tmp/requirements.txt"
  mkdir -p "$oidn_dir/lib"
  python3 - "$tmp"/pyoidn-*.whl "$oidn_dir/lib" <<'PY'
import re, sys, zipfile, os
wheel, out = sys.argv[1], sys.argv[2]
keep = re.compile(r"pyoidn/oidn/lib/(libOpenImageDenoise(_core|_device_cpu)?\.so[.0-9]*|libtbb\.so[.0-9]*)$")
with zipfile.ZipFile(wheel) as z:
    for name in z.namelist():
        if keep.match(name):
            target = os.path.join(out, os.path.basename(name))
            with z.open(name) as src, open(target + ".part", "wb") as dst:
                dst.write(src.read())
            os.replace(target + ".part", target)
PY
  rm -rf "$tmp"
fi

command -v cargo >/dev/null || { echo "setup: cargo is missing; install Rust with rustup (https://rustup.rs), then run this again" >&2; exit 1; }

# The formatter and the linter the test command runs first.
for component in rustfmt clippy; do
  rustup component list --installed 2>/dev/null | grep -q "^$component" || rustup component add "$component"
done

# The web viewer: the wasm32 target and wasm-bindgen's CLI at the version
# the viewer pins (they must match), then the build itself (web/build.sh),
# which `exploremaps build` copies into every bundle.
rustup target list --installed 2>/dev/null | grep -q wasm32-unknown-unknown || rustup target add wasm32-unknown-unknown
if [ "$(wasm-bindgen --version 2>/dev/null)" != "wasm-bindgen 0.2.130" ]; then
  echo "setup: installing wasm-bindgen-cli 0.2.130 (about 4 minutes)"
  cargo install --quiet wasm-bindgen-cli --version 0.2.130
fi
# Playwright (the library only; it drives Debian's Chromium) for the browser tests, and iwer
# (Meta's WebXR emulator, injected into the page for the headset test).
# The tour viewers `exploremaps export` writes for, at the versions it pins
# (builder/src/export/mod.rs), for the export tests (--library target/node/node_modules).
node_dir="$(cd "$(dirname "$0")/.." && pwd)/target/node"
if [ ! -e "$node_dir/node_modules/playwright-core/index.mjs" ] || [ ! -e "$node_dir/node_modules/@photo-sphere-viewer/virtual-tour-plugin/index.module.js" ] \
  || [ ! -e "$node_dir/node_modules/iwer/build/iwer.js" ]; then
  mkdir -p "$node_dir"
  npm install --prefix "$node_dir" --no-audit --no-fund --silent playwright-core@1.65.1 \
    pannellum@2.5.7 marzipano@0.10.2 three@0.185.1 @photo-sphere-viewer/core@5.15.1 \
    @photo-sphere-viewer/cubemap-adapter@5.15.1 @photo-sphere-viewer/cubemap-tiles-adapter@5.15.1 \
    @photo-sphere-viewer/virtual-tour-plugin@5.15.1 iwer@2.5.0
fi
echo "setup: building the web viewer"
"$(dirname "$0")/../web/build.sh"
echo "setup: ready"
