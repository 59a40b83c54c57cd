#!/usr/bin/env bash
# The viewer and the glTF mesh-out, tested outside Rust: installs the npm packages of
# web/package.json (three.js, the Khronos glTF validator, glTF-Transform, playwright-core),
# builds the demo (web/build.sh, with the debug patchvis binary), then
#   1. bakes tests/data/obj/globe.obj (textured) to .glb and .gltf and checks both with two
#      independent readers (tests/web/check_gltf.mjs);
#   2. drives web/ in headless Chromium (tests/web/viewer.mjs): 33 camera positions over every
#      band of the bunny's shells, near the model and up to 1000 sampling distances out,
#      against `patchvis query`, a dropped .glb + .pvis pair, no console errors, the first
#      view clear of the overlay; the screenshot goes to tests/web/out/viewer.png
#      (docs/viewer.png is one).
# Used by .ci/run; needs Node 18 or newer, npm and Chromium (CHROMIUM, default
# /usr/bin/chromium: Debian's `chromium` package).
set -euo pipefail
cd "$(dirname "$0")/../.."
if [ ! -d web/node_modules/playwright-core ] || [ ! -d web/node_modules/gltf-validator ]; then
  npm ci --prefix web --no-audit --no-fund --silent
fi
cargo build --quiet --bin patchvis
target=$(cargo metadata --format-version 1 --no-deps | node -e 'let s="";process.stdin.on("data",d=>s+=d).on("end",()=>console.log(JSON.parse(s).target_directory))')
export PATCHVIS="$target/debug/patchvis"
bash web/build.sh
out=tests/web/out
mkdir -p "$out"
for ext in glb gltf; do
  "$PATCHVIS" bake tests/data/obj/globe.obj -o "$out/globe.pvis" --mesh-out "$out/globe.$ext" \
    --patches 16 --quiet
  node tests/web/check_gltf.mjs "$out/globe.$ext" "$out/globe.pvis"
done
cp "$out/globe.glb" "$out/globe.pvis" web/demo/
node tests/web/viewer.mjs "$PATCHVIS" "$out/viewer.png"
