#!/usr/bin/env bash
# Builds the .pvis reader for WebAssembly: wasm/patchvis.wasm (the C ABI of src/capi.rs as
# wasm exports, no_std, no allocator), for wasm/patchvis.mjs. Needs the wasm32-unknown-unknown
# Rust target (`rustup target add wasm32-unknown-unknown`). Prints the size raw and gzipped.
set -euo pipefail
cd "$(dirname "$0")/.."
target=${CARGO_TARGET_DIR:-target}/wasm
cargo rustc --quiet --profile wasm --lib --no-default-features --features wasm \
    --target wasm32-unknown-unknown --crate-type cdylib --target-dir "$target"
cp "$target/wasm32-unknown-unknown/wasm/patchvis.wasm" wasm/patchvis.wasm
raw=$(wc -c < wasm/patchvis.wasm)
gz=$(gzip -9 -c wasm/patchvis.wasm | wc -c)
echo "wasm/patchvis.wasm: $raw bytes, $gz gzipped"
