#!/usr/bin/env bash
# Fuzzes the .cgv reader and the decoder for a short time each (default 60 s;
# FUZZ_SECONDS=600 for longer). Seeds come from tests/fixtures and from
# files the encoder writes on the spot. Needs cargo-fuzz (installed here on
# first use) and libFuzzer's nightly flags, which RUSTC_BOOTSTRAP enables on
# the stable toolchain.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
source pkg-scripts/setup.sh
seconds="${FUZZ_SECONDS:-60}"

if ! cargo fuzz --version >/dev/null 2>&1; then
  echo "[fuzz] installing cargo-fuzz" >&2
  CARGO_TARGET_DIR="$HOME/.cache/cgv/cargo-fuzz-build" cargo install -q cargo-fuzz --root "$HOME/.cache/cgv/tools"
  rm -rf "$HOME/.cache/cgv/cargo-fuzz-build"
fi

# Seed corpus: real files from the encoder.
corpus=fuzz/corpus/read
mkdir -p "$corpus" fuzz/corpus/decode
cargo build --release --bin cgv
cgv="$CARGO_TARGET_DIR/release/cgv"
for codec in gv cgv; do
  [ -e "$corpus/walk-$codec.cgv" ] || "$cgv" encode builtin:walk --codec "$codec" --grid 16 --qp 30 -o "$corpus/walk-$codec.cgv" >/dev/null
  cp "$corpus/walk-$codec.cgv" fuzz/corpus/decode/
done
[ -e "$corpus/walk-motion.cgv" ] || "$cgv" encode builtin:walk --corrections motion --grid 16 --qp 30 -o "$corpus/walk-motion.cgv" >/dev/null
cp "$corpus/walk-motion.cgv" fuzz/corpus/decode/
# Every frozen fixture, so both container layouts are seeded.
for v in tests/fixtures/v*; do
  for f in "$v"/*.cgv; do cp "$f" "$corpus/$(basename "$v")-$(basename "$f")"; done
done

export RUSTC_BOOTSTRAP=1
# Fuzz builds go to their own folder (sanitizer flags rebuild everything).
export CARGO_TARGET_DIR="$HOME/.cache/cgv/fuzz-target"
for target in read decode; do
  echo "[fuzz] $target for $seconds s" >&2
  (cd fuzz && cargo fuzz run "$target" "corpus/$target" -- -max_total_time="$seconds" -rss_limit_mb=2048 -max_len=65536)
done
