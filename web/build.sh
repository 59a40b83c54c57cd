#!/usr/bin/env bash
# Builds the viewer's demo: turns the bundled bunny (assets/bunny.ply, Z up) to glTF's axes
# (web/bunny-y-up.mjs), bakes it into web/demo/bunny.pvis with its mesh as web/demo/bunny.glb
# (`--mesh-out`), builds the WebAssembly reader (wasm/build.sh) and copies the npm package's
# files (npm/: the module, the .wasm and the three.js helper) into web/demo/patchvis/, where
# index.html's import map finds them, and installs three.js into web/node_modules (npm, from
# web/package-lock.json). Then serve web/:
#
#   python3 -m http.server -d web 8000     # and open http://localhost:8000/
#
# PATCHVIS=/path/to/patchvis uses that binary instead of `cargo run --release`. Needs cargo,
# the wasm32-unknown-unknown target, Node and npm.
set -euo pipefail
cd "$(dirname "$0")/.."
mkdir -p web/demo
if [ -n "${PATCHVIS:-}" ]; then
  patchvis() { "$PATCHVIS" "$@"; }
else
  patchvis() { cargo run --quiet --release --bin patchvis -- "$@"; }
fi
# The default bake, sampling shells included: the page's reader answers from them, so the
# viewer culls near the model too. The mesh upright in glTF's axes (Y up, facing +Z), as the
# viewer shows a .glb.
node web/bunny-y-up.mjs assets/bunny.ply web/demo/bunny-y-up.ply
patchvis bake web/demo/bunny-y-up.ply -o web/demo/bunny.pvis --mesh-out web/demo/bunny.glb --quiet
bash wasm/build.sh
mkdir -p web/demo/patchvis
cp npm/patchvis.mjs npm/patchvis.wasm npm/three.mjs web/demo/patchvis/
if [ ! -d web/node_modules/three ]; then
  npm ci --prefix web --omit=dev --no-audit --no-fund --silent
fi
echo "web/demo: bunny.glb, bunny.pvis, patchvis/ (the npm package); serve with: python3 -m http.server -d web 8000"
