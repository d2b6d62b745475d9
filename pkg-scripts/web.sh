#!/usr/bin/env bash
# Builds the web viewer's package: the library for wasm32, wasm-bindgen
# (--target web) into www/pkg/ (ignored), then binaryen's wasm-opt -O2.
# Runs on its own: it sets up what is missing first (the wasm target,
# wasm-bindgen-cli, CARGO_TARGET_DIR and PATH; quick when all is there).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
source pkg-scripts/setup.sh
cargo build --release --lib --target wasm32-unknown-unknown
wasm="$CARGO_TARGET_DIR/wasm32-unknown-unknown/release/cgv.wasm"
rm -rf www/pkg
wasm-bindgen --target web --out-dir www/pkg "$wasm"
# binaryen's wasm-opt from npm (www/package.json pins it; setup.sh runs npm
# ci in www): Debian's binaryen 108 writes a module Chromium refuses
# ("WebAssembly.Table.set(): Argument 1 is invalid for table").
opt=www/node_modules/.bin/wasm-opt
if [ -x "$opt" ]; then
  "$opt" -O2 www/pkg/cgv_bg.wasm -o www/pkg/cgv_bg.wasm
else
  echo "web package: $opt is missing (npm ci in www): not optimized" >&2
fi
size=$(stat -c %s www/pkg/cgv_bg.wasm)
gz=$(gzip -9c www/pkg/cgv_bg.wasm | wc -c)
echo "web package: www/pkg/ (cgv_bg.wasm $size bytes, $gz gzipped)"
