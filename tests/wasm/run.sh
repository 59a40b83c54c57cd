#!/usr/bin/env bash
# Builds the WebAssembly reader (wasm/build.sh) and runs tests/wasm/conformance.mjs with Node:
# every conformance vector's queries and refusals through wasm/patchvis.mjs. Used by .ci/run;
# needs the wasm32-unknown-unknown Rust target and Node 18 or newer.
set -euo pipefail
cd "$(dirname "$0")/../.."
bash wasm/build.sh
node tests/wasm/conformance.mjs
