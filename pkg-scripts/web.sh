#!/usr/bin/env bash
# Builds the web viewer's two packages, each the library for wasm32 through
# wasm-bindgen (--target web) and binaryen's wasm-opt, into ignored folders:
#   www/pkg/          the decoder and the wgpu renderer (<cgv-player>)
#   www/pkg-decoder/  the decoder alone, without the `render` feature
#                     (container, reconstruction; H.264 is the browser's),
#                     for pages that draw themselves (www/three/)
# Runs on its own: it sets up what is missing first (the wasm target,
# wasm-bindgen-cli, CARGO_TARGET_DIR and PATH; quick when all is there).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
source pkg-scripts/setup.sh
# binaryen's wasm-opt from npm (www/package.json pins it; setup.sh runs npm
# ci in www): Debian's binaryen 108 writes a module Chromium refuses
# ("WebAssembly.Table.set(): Argument 1 is invalid for table").
opt=www/node_modules/.bin/wasm-opt

# package OUT_DIR LEVEL [CARGO_FLAGS...]
package() {
  local out=$1 level=$2
  shift 2
  cargo build --release --lib --target wasm32-unknown-unknown "$@"
  rm -rf "$out"
  wasm-bindgen --target web --out-dir "$out" "$CARGO_TARGET_DIR/wasm32-unknown-unknown/release/cgv.wasm"
  if [ -x "$opt" ]; then
    "$opt" "$level" "$out/cgv_bg.wasm" -o "$out/cgv_bg.wasm"
  else
    echo "web package: $opt is missing (npm ci in www): not optimized" >&2
  fi
  echo "web package: $out/ (cgv_bg.wasm $(stat -c %s "$out/cgv_bg.wasm") bytes, $(gzip -9c "$out/cgv_bg.wasm" | wc -c) gzipped)"
}

# The decoder first, so that the last build left in the target folder is
# the full one, which `cargo test --target wasm32-unknown-unknown` reuses.
# -Oz for the small first download (measured: 234 KB gzipped against -O2's
# 238 KB); -O2 for the renderer (its draw loop is hot).
package www/pkg-decoder -Oz --no-default-features
package www/pkg -O2
