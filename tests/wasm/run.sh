#!/usr/bin/env bash
# Builds the WebAssembly reader (wasm/build.sh), a full reader with the sampling shells, and
# runs tests/wasm/conformance.mjs with Node: every conformance vector's `query` lines and
# refusals through npm/patchvis.mjs (the npm package's module, from the source tree;
# tests/npm/run.sh runs the same test against the packed and installed package); then the same
# module through `patchvis conformance --reader 'node tests/wasm/adapter.mjs'`. Used by
# .ci/run; needs the wasm32-unknown-unknown Rust
# target and Node 18 or newer. Where npm is present it first installs web/package.json's
# packages (binaryen's wasm-opt among them), and then the module must meet its size targets:
# at most 32,000 bytes, 13,000 gzipped.
set -euo pipefail
cd "$(dirname "$0")/../.."
if [ -z "${WASM_OPT:-}" ] && [ ! -x web/node_modules/.bin/wasm-opt ] && command -v npm >/dev/null; then
  npm ci --prefix web --no-audit --no-fund --silent
fi
built=$(bash wasm/build.sh)
echo "$built"
node tests/wasm/conformance.mjs
# The module through the conformance harness (tests/conformance/README.md, "Testing another
# reader"), truncated copies of every valid vector included.
cargo build --quiet --bin patchvis
harness=$("${CARGO_TARGET_DIR:-target}/debug/patchvis" conformance --reader 'node tests/wasm/adapter.mjs') ||
  { grep -v '^pass ' <<< "$harness"; echo "wasm reader: conformance harness FAILED" >&2; exit 1; }
tail -n 1 <<< "$harness"
raw=$(wc -c < npm/patchvis.wasm)
gz=$(gzip -9 -c npm/patchvis.wasm | wc -c)
if [[ $built == *"wasm-opt -Oz"* ]] && { [ "$raw" -gt 32000 ] || [ "$gz" -gt 13000 ]; }; then
  echo "npm/patchvis.wasm is $raw bytes, $gz gzipped: over the 32,000 / 13,000-byte targets" >&2
  exit 1
fi
