#!/usr/bin/env bash
# The npm package (npm/) as a user installs it: `npm pack`, the tarball's file list, then an
# empty folder with this folder's project (TypeScript pinned in package-lock.json) and the
# tarball installed into it; then
#   1. tests/wasm/conformance.mjs against the installed package's module and .wasm (resolved
#      by name, `patchvis`, as an application imports it), not the source tree's;
#   2. three_helper.mjs: the installed three.js helper on a stand-in model;
#   3. `tsc --noEmit` on example.ts, against the installed package's types.
# Used by .ci/run after tests/wasm/run.sh (which builds npm/patchvis.wasm); builds it itself
# if it is missing. Needs Node 18+ and npm (the registry for TypeScript).
set -euo pipefail
cd "$(dirname "$0")/../.."
[ -f npm/patchvis.wasm ] || bash wasm/build.sh
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
tarball="$work/$(cd npm && npm pack --silent --pack-destination "$work")"
want="package/README.md package/package.json package/patchvis.d.ts package/patchvis.mjs package/patchvis.wasm package/three.d.ts package/three.mjs"
got=$(tar -tzf "$tarball" | sort | tr '\n' ' ' | sed 's/ $//')
if [ "$got" != "$want" ]; then
  echo "npm pack: the package holds [$got], expected [$want]" >&2
  exit 1
fi
echo "npm pack: $(basename "$tarball"), $(wc -c < "$tarball") bytes: $got"
app="$work/app"
mkdir "$app"
cp tests/npm/package.json tests/npm/package-lock.json tests/npm/tsconfig.json tests/npm/example.ts \
  tests/npm/three_helper.mjs "$app/"
(cd "$app" && npm ci --no-audit --no-fund --silent && npm install --no-save --no-audit --no-fund --silent "$tarball")
resolve() { (cd "$app" && node --input-type=module -e "console.log(new URL(import.meta.resolve('$1')).pathname)"); }
module=$(resolve patchvis)
helper=$(resolve patchvis/three)
case "$module$helper" in
  "$app"/node_modules/patchvis/patchvis.mjs"$app"/node_modules/patchvis/three.mjs) ;;
  *) echo "patchvis resolves to $module and $helper, not the installed package" >&2; exit 1 ;;
esac
PATCHVIS_MODULE="$module" node tests/wasm/conformance.mjs
(cd "$app" && node three_helper.mjs)
(cd "$app" && node_modules/.bin/tsc --noEmit -p . && echo "tsc --noEmit: example.ts type-checks against the installed package")
