#!/usr/bin/env bash
# Set up what is missing, then run every check: formatting, clippy, the web
# package (wasm32 + wasm-bindgen), all tests (including those on
# ../shared/data and the viewer in headless Chromium, which uses the
# package), and the fuzz targets for 30 s each (FUZZ_SECONDS to change it).
# Benchmarks are compiled by clippy and run by `cargo bench`, not here.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
source pkg-scripts/setup.sh

step() { printf '\n\033[1m== %s\033[0m\n' "$*"; }

step "cargo fmt --check"
cargo fmt --all -- --check
cargo fmt --manifest-path python/Cargo.toml -- --check

step "cargo clippy (native, all targets)"
cargo clippy --release --all-targets -- -D warnings
cargo clippy --release --manifest-path python/Cargo.toml -- -D warnings

step "web package (wasm32, wasm-bindgen) into www/pkg"
bash pkg-scripts/web.sh

step "tests (native, and the viewer in headless Chromium)"
log="$(mktemp)"
trap 'rm -f "$log"' EXIT
cargo test --release 2>&1 | tee "$log"
# The stress corpus's 100k-vertex mesh (ignored in a plain `cargo test`).
cargo test --release --test fold_free -- --ignored 2>&1 | tee -a "$log"

step "wasm tests in headless Chromium (wasm-bindgen-test)"
export CHROMEDRIVER="${CHROMEDRIVER:-$(command -v chromedriver)}"
export WASM_BINDGEN_TEST_WEBDRIVER_JSON="$PWD/pkg-scripts/webdriver.json"
cargo test --release --target wasm32-unknown-unknown --test web 2>&1 | tee -a "$log"
step "Python package: a wheel built with maturin, installed, its tests (pytest)"
# A build folder of its own (python/Cargo.toml says why).
wheels="$CARGO_TARGET_DIR-python/wheels"
rm -rf "$wheels"
CARGO_TARGET_DIR="$CARGO_TARGET_DIR-python" "$CGV_VENV/bin/maturin" build --release --quiet -m python/Cargo.toml -o "$wheels"
"$CGV_VENV/bin/pip" install -q --disable-pip-version-check --force-reinstall --no-deps "$wheels"/cgv-*.whl
CGV_REQUIRE_RAY=1 CGV_BIN="$CARGO_TARGET_DIR/release/cgv" "$CGV_VENV/bin/python" -m pytest -q -p no:cacheprovider python/tests 2>&1 | tee -a "$log"

step "fuzz targets, ${FUZZ_SECONDS:-30} s each (pkg-scripts/fuzz.sh)"
FUZZ_SECONDS="${FUZZ_SECONDS:-30}" FUZZ_SANITIZER=none bash pkg-scripts/fuzz.sh

# One closing line for the whole run (cargo prints one per test binary,
# and pytest one: "N passed[, M failed] in Ts").
awk '/^test result:/ { for (i = 2; i <= NF; i++) { if ($i == "passed;") p += $(i-1); if ($i == "failed;") f += $(i-1) } }
     /^[0-9]+ (passed|failed).* in [0-9.]+s/ { for (i = 2; i <= NF; i++) { if ($i ~ /^passed,?$/) p += $(i-1); if ($i ~ /^failed,?$/) f += $(i-1) } }
     END { printf "tests: %d passed, %d failed\n", p, f }' "$log"
