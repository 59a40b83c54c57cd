#!/usr/bin/env bash
# Builds the .pvis reader for WebAssembly: npm/patchvis.wasm (the C ABI of src/capi.rs as
# wasm exports, no_std, no allocator), for npm/patchvis.mjs: the npm package's two files
# (npm/README.md). Needs the wasm32-unknown-unknown
# Rust target (`rustup target add wasm32-unknown-unknown`). Then, where binaryen's wasm-opt
# from npm is installed (web/package.json's devDependency: `npm ci --prefix web`; or WASM_OPT
# naming one), shrinks it with `wasm-opt -Oz` (about 2 KB raw, 0.4 KB gzipped). Prints the
# size raw and gzipped.
set -euo pipefail
cd "$(dirname "$0")/.."
target=${CARGO_TARGET_DIR:-target}/wasm
cargo rustc --quiet --profile wasm --lib --no-default-features --features wasm \
    --target wasm32-unknown-unknown --crate-type cdylib --target-dir "$target"
built="$target/wasm32-unknown-unknown/wasm/patchvis.wasm"
wasm_opt=${WASM_OPT:-web/node_modules/.bin/wasm-opt}
if [ -x "$wasm_opt" ]; then
  # The features rustc's wasm32-unknown-unknown enables (the stripped module no longer says
  # which), so that wasm-opt neither refuses the code nor adds instructions beyond them.
  "$wasm_opt" -Oz --enable-bulk-memory --enable-sign-ext --enable-mutable-globals \
    --enable-nontrapping-float-to-int --enable-multivalue --enable-reference-types \
    "$built" -o npm/patchvis.wasm
  how="rustc + wasm-opt -Oz"
else
  cp "$built" npm/patchvis.wasm
  how="rustc only: no wasm-opt at $wasm_opt"
fi
raw=$(wc -c < npm/patchvis.wasm)
gz=$(gzip -9 -c npm/patchvis.wasm | wc -c)
echo "npm/patchvis.wasm: $raw bytes, $gz gzipped ($how)"
