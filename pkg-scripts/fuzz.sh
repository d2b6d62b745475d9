#!/usr/bin/env bash
# Fuzzes the .cgv reader and the decoder for a while each: FUZZ_SECONDS per
# target (default 60; test.sh runs 30, and before a release run it for
# longer by hand: FUZZ_SECONDS=3600). Seeds come from tests/fixtures, from
# tests/fuzz-regressions and from files the encoder writes on the spot. A
# crash is copied into tests/fuzz-regressions (where tests/fuzz_regressions.rs
# runs it from then on) and fails the run. Needs cargo-fuzz (installed here
# on first use) and libFuzzer's nightly flags, which RUSTC_BOOTSTRAP enables
# on the stable toolchain. FUZZ_SANITIZER: address (default) or none (what
# test.sh uses: a quicker build, and OpenH264's C code is not instrumented
# either way).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
source pkg-scripts/setup.sh
seconds="${FUZZ_SECONDS:-60}"
sanitizer="${FUZZ_SANITIZER:-address}"
say() { printf '\033[1m[fuzz]\033[0m %s\n' "$*" >&2; }

if ! cargo fuzz --version >/dev/null 2>&1; then
  say "installing cargo-fuzz (once)"
  CARGO_TARGET_DIR="$HOME/.cache/cgv/cargo-fuzz-build" cargo install -q cargo-fuzz --root "$HOME/.cache/cgv/tools"
  rm -rf "$HOME/.cache/cgv/cargo-fuzz-build"
fi

# Seed corpus: real files from the encoder, the fixtures, the regressions.
# The encoder's files are made once (a binary the tests already built will
# do: they are only seeds).
cgv="$CARGO_TARGET_DIR/release/cgv"
[ -x "$cgv" ] || cargo build --release --bin cgv
mkdir -p fuzz/corpus/read fuzz/corpus/decode
seed() { for f in "$@"; do for t in read decode; do cp "$f" "fuzz/corpus/$t/$(basename "$(dirname "$f")")-$(basename "$f")"; done; done; }
# (Without the figure's 6274-vertex mesh, which is larger than -max_len;
# an icosahedron's stands for format version 6's source mesh.)
for codec in gv cgv; do
  f="fuzz/corpus/read/walk-$codec.cgv"
  [ -e "$f" ] || "$cgv" encode builtin:walk --codec "$codec" --grid 16 --qp 30 --no-source-mesh -o "$f" >/dev/null
  cp "$f" fuzz/corpus/decode/
done
f=fuzz/corpus/read/walk-motion.cgv
[ -e "$f" ] || "$cgv" encode builtin:walk --corrections motion --grid 16 --qp 30 --no-source-mesh -o "$f" >/dev/null
cp "$f" fuzz/corpus/decode/
# Bones, packed since version 14 (the fixture's source mesh is past -max_len).
f=fuzz/corpus/read/walk-bones-packed.cgv
[ -e "$f" ] || "$cgv" encode builtin:walk --corrections motion --grid 16 --qp 30 --no-source-mesh --bones 4 -o "$f" >/dev/null
cp "$f" fuzz/corpus/decode/
f=fuzz/corpus/read/icosahedron-source.cgv
if [ ! -e "$f" ]; then
  awk 'BEGIN { t = (1 + sqrt(5)) / 2
    split("-1 t 0 1 t 0 -1 -t 0 1 -t 0 0 -1 t 0 1 t 0 -1 -t 0 1 -t t 0 -1 t 0 1 -t 0 -1 -t 0 1", v, " ")
    for (i = 1; i <= 36; i += 3) { o = ""; for (k = 0; k < 3; k++) { x = v[i + k]; x = (x == "t") ? t : (x == "-t") ? -t : x; o = o " " x }; print "v" o }
    split("1 12 6 1 6 2 1 2 8 1 8 11 1 11 12 2 6 10 6 12 5 12 11 3 11 8 7 8 2 9 4 10 5 4 5 3 4 3 7 4 7 9 4 9 10 5 10 6 3 5 12 7 3 11 9 7 8 10 9 2", f, " ")
    for (i = 1; i <= 60; i += 3) print "f", f[i], f[i + 1], f[i + 2] }' > fuzz/corpus/icosahedron.obj
  "$cgv" encode fuzz/corpus/icosahedron.obj --grid 16 --qp 30 -o "$f" >/dev/null
fi
cp "$f" fuzz/corpus/decode/
# Bones on the vertices (format v17), small enough for -max_len.
f=fuzz/corpus/read/icosahedron-skinned.cgv
[ -e "$f" ] || "$cgv" encode fuzz/corpus/icosahedron.obj --codec skinned --bones 2 --grid 16 --qp 30 -o "$f" >/dev/null
cp "$f" fuzz/corpus/decode/
seed tests/fixtures/v*/*.cgv
seed $(find tests/fuzz-regressions -type f ! -name '*.md')

export RUSTC_BOOTSTRAP=1
# Fuzz builds go to their own folder (sanitizer flags rebuild everything).
export CARGO_TARGET_DIR="$HOME/.cache/cgv/fuzz-target-$sanitizer"
# Both targets at once, one core each (libFuzzer runs one process here):
# built first, so the two runs do not wait on each other's build.
(cd fuzz && cargo fuzz build --sanitizer "$sanitizer")
pids=()
for target in read decode; do
  say "$target for $seconds s"
  rm -rf "fuzz/artifacts/$target"
  (cd fuzz && cargo fuzz run --sanitizer "$sanitizer" "$target" "corpus/$target" -- \
    -max_total_time="$seconds" -rss_limit_mb=2048 -max_len=65536 -print_final_stats=1) > "fuzz/$target.log" 2>&1 &
  pids+=($!)
done
failed=0
for i in 0 1; do
  target=$([ $i = 0 ] && echo read || echo decode)
  status=0
  wait "${pids[$i]}" || status=$?
  tail -n 12 "fuzz/$target.log" >&2
  found=$(find "fuzz/artifacts/$target" -type f 2>/dev/null || true)
  if [ -n "$found" ] || [ "$status" -ne 0 ]; then
    mkdir -p tests/fuzz-regressions
    for f in $found; do cp "$f" "tests/fuzz-regressions/$target-$(basename "$f")"; done
    say "$target failed (exit $status; log fuzz/$target.log); inputs kept in tests/fuzz-regressions: ${found:-none}"
    failed=1
  fi
done
[ "$failed" = 0 ] || exit 1
say "no crash in ${seconds} s per target"
