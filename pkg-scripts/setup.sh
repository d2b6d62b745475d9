#!/usr/bin/env bash
# Installs whatever cgv needs that this machine lacks; fast when all is there.
# Sourced by demo.sh and test.sh (it exports CARGO_TARGET_DIR and PATH).
#
#   rustup target wasm32-unknown-unknown     the web build
#   wasm-bindgen-cli, pinned to Cargo.lock   the web package (installed under ~/.cache/cgv)
#   nasm                                     openh264's assembly (2-5x faster H.264)
#   g++                                      openh264 and meshoptimizer (the `meshopt` crate) are C++
#   chromium, chromium-driver                browser tests
#   mesa-vulkan-drivers                      lavapipe, for rendering without a GPU
#   nodejs, npm; tests/node (npm ci)         the Khronos glTF-Validator the tests run on our GLBs, and
#                                            gltfpack + meshoptimizer for cgv.peers
#   www (npm ci)                             three.js, for www/three/ (the three.js module's demo), and
#                                            binaryen's wasm-opt for the web package (1.46 -> 1.29 MB gzipped)
#   python3-venv; python/requirements-dev.txt the Python package's build (maturin) and tests (numpy,
#                                            pytest, Ray, DracoPy), in a virtual environment under ~/.cache/cgv
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cache="${CGV_CACHE:-$HOME/.cache/cgv}"
# One build folder outside the clone, shared by the demo, the tests and CI runs.
export CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-$cache/target}"
export PATH="$cache/tools/bin:$HOME/.cargo/bin:$PATH"
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp}"

say() { printf '\033[1m[setup]\033[0m %s\n' "$*" >&2; }

if ! command -v cargo >/dev/null; then
  echo "cargo not found: install Rust with rustup (https://rustup.rs) first" >&2
  exit 1
fi

if command -v rustup >/dev/null && ! rustup target list --installed | grep -qx wasm32-unknown-unknown; then
  say "adding the wasm32-unknown-unknown target"
  rustup target add wasm32-unknown-unknown
fi

missing=()
command -v nasm >/dev/null || missing+=(nasm)
command -v c++ >/dev/null || missing+=(g++)
command -v chromium >/dev/null || missing+=(chromium)
command -v chromedriver >/dev/null || missing+=(chromium-driver)
command -v xz >/dev/null || missing+=(xz-utils)
command -v python3 >/dev/null && python3 -c 'import ensurepip, venv' 2>/dev/null || missing+=(python3 python3-venv)
command -v node >/dev/null || missing+=(nodejs)
command -v npm >/dev/null || missing+=(npm)
# A TrueType font for the labels of `cgv eval --plot` (plotters lays text out with one).
[ -e /usr/share/fonts/truetype/dejavu/DejaVuSans.ttf ] || [ -e /usr/share/fonts/truetype/liberation/LiberationSans-Regular.ttf ] || missing+=(fonts-dejavu-core)
[ -e /usr/share/vulkan/icd.d/lvp_icd.x86_64.json ] || ls /usr/share/vulkan/icd.d/lvp_icd*.json >/dev/null 2>&1 || missing+=(mesa-vulkan-drivers)
if [ ${#missing[@]} -gt 0 ]; then
  say "installing ${missing[*]} with apt"
  sudo=""; [ "$(id -u)" -eq 0 ] || sudo="sudo"
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq "${missing[@]}" >/dev/null
fi

# wasm-bindgen-cli must match the wasm-bindgen version in Cargo.lock exactly.
want="$(awk '/^name = "wasm-bindgen"$/ {getline; gsub(/"/, "", $3); print $3; exit}' "$here/Cargo.lock")"
have="$(wasm-bindgen --version 2>/dev/null | awk '{print $2}' || true)"
if [ -n "$want" ] && [ "$have" != "$want" ]; then
  say "installing wasm-bindgen-cli $want (takes several minutes once)"
  # Its own build folder, so it does not hold the project's build lock; not
  # --locked: its lock file pins a crate release the registry lacks.
  CARGO_TARGET_DIR="$cache/wasm-bindgen-build" cargo install -q wasm-bindgen-cli --version "$want" --root "$cache/tools"
  rm -rf "$cache/wasm-bindgen-build"
fi

# three.js (the three.js module's demo page and its test) and wasm-opt, pinned by www/package-lock.json.
if [ ! -d "$here/www/node_modules/three" ] || [ ! -x "$here/www/node_modules/.bin/wasm-opt" ]; then
  say "installing three.js and binaryen (npm ci in www)"
  (cd "$here/www" && npm ci --no-audit --no-fund --silent)
fi

# The glTF-Validator for the tests and the peers (gltfpack, meshoptimizer), pinned by tests/node/package-lock.json.
if [ ! -d "$here/tests/node/node_modules/gltf-validator" ] || [ ! -d "$here/tests/node/node_modules/gltfpack" ]; then
  say "installing the Khronos glTF-Validator, gltfpack and meshoptimizer (npm ci in tests/node)"
  (cd "$here/tests/node" && npm ci --no-audit --no-fund --silent)
fi

# The Python package's tools, in their own virtual environment (CGV_VENV).
export CGV_VENV="$cache/venv"
if [ ! -x "$CGV_VENV/bin/python" ]; then
  say "making a Python virtual environment in $CGV_VENV"
  python3 -m venv "$CGV_VENV"
fi
if ! cmp -s "$here/python/requirements-dev.txt" "$CGV_VENV/requirements-dev.txt"; then
  say "installing maturin, numpy, pytest, Ray and DracoPy into $CGV_VENV (python/requirements-dev.txt)"
  "$CGV_VENV/bin/pip" install -q --disable-pip-version-check -r "$here/python/requirements-dev.txt"
  cp "$here/python/requirements-dev.txt" "$CGV_VENV/requirements-dev.txt"
fi

# Mesa (lavapipe) warns without a runtime dir; harmless, but noisy in logs.
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp}"
