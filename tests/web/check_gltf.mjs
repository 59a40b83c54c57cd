// Checks a `patchvis bake --mesh-out` glTF of tests/data/obj/globe.obj with readers that are
// not patchvis's: the Khronos glTF validator (no errors, no warnings) and glTF-Transform
// (loads it; attributes, materials, texture), and its patch ranges against the .pvis through
// the WebAssembly reader (every query's ranges are unions of the glTF's patch ranges, in the
// glTF's triangle order). Used by tests/web/run.sh.
//
//   node tests/web/check_gltf.mjs FILE.glb|FILE.gltf FILE.pvis
import { createRequire } from "node:module";
import { readFile } from "node:fs/promises";
import { Reader } from "../../npm/patchvis.mjs";

const [path, pvisPath] = process.argv.slice(2);
// The test's npm packages live in web/node_modules (web/package.json).
const web = createRequire(new URL("../../web/package.json", import.meta.url));
const validator = web("gltf-validator");
const { NodeIO } = web("@gltf-transform/core");
const fail = (what) => {
  console.error(`${path}: ${what}`);
  process.exit(1);
};
const bytes = new Uint8Array(await readFile(path));

// 1. The Khronos validator.
const noExternal = () => Promise.reject(new Error("the file must be self-contained"));
const report = path.endsWith(".glb")
  ? await validator.validateBytes(bytes, { externalResourceFunction: noExternal })
  : await validator.validateString(new TextDecoder().decode(bytes), { externalResourceFunction: noExternal });
const { numErrors, numWarnings, messages } = report.issues;
if (numErrors > 0 || numWarnings > 0) {
  fail(`${numErrors} errors, ${numWarnings} warnings:\n${JSON.stringify(messages.filter((m) => m.severity < 2), null, 1)}`);
}

// 2. glTF-Transform.
const io = new NodeIO();
const doc = path.endsWith(".glb")
  ? await io.readBinary(bytes)
  : await io.readJSON({ json: JSON.parse(new TextDecoder().decode(bytes)), resources: {} });
const root = doc.getRoot();
const [mesh, ...others] = root.listMeshes();
if (!mesh || others.length > 0) fail("expected one mesh");
const extras = mesh.getExtras().patchvis;
const firsts = extras.patch_first_triangle;
let next = 0;
for (const primitive of mesh.listPrimitives()) {
  const semantics = primitive.listSemantics().sort().join(",");
  if (semantics !== "NORMAL,POSITION,TEXCOORD_0") fail(`attributes ${semantics}`);
  const { first_triangle: first, triangle_count: count } = primitive.getExtras().patchvis;
  if (first !== next || primitive.getIndices().getCount() !== 3 * count) fail(`primitive at ${first}, expected ${next}`);
  next += count;
  const uv = primitive.getAttribute("TEXCOORD_0");
  const e = [];
  for (let v = 0; v < uv.getCount(); v++) {
    uv.getElement(v, e);
    if (!(e[0] >= 0 && e[0] <= 1 && e[1] >= 0 && e[1] <= 1)) fail(`texture coordinate ${v} is ${e}`);
  }
  if (!primitive.getMaterial()) fail(`the primitive at ${first} has no material`);
}
if (next !== extras.triangle_count) fail(`primitives cover ${next} of ${extras.triangle_count} triangles`);
const materials = root.listMaterials().map((m) => {
  const texture = m.getBaseColorTexture();
  return [m.getName(), m.getBaseColorFactor().map((c) => +c.toFixed(3)), texture && texture.getMimeType(), texture && texture.getSize()];
});
const expected = [["checker", [1, 1, 1, 1], "image/png", [8, 8]], ["paint", [0.2, 0.4, 0.8, 1], null, null]];
if (JSON.stringify(materials) !== JSON.stringify(expected)) fail(`materials ${JSON.stringify(materials)}`);

// 3. The .pvis, through the WebAssembly reader: patch counts, and every query's ranges as
// unions of the glTF's patch ranges.
const reader = await Reader.load(await readFile(new URL("../../npm/patchvis.wasm", import.meta.url)));
const file = reader.open(await readFile(pvisPath));
if (file.patchCount !== extras.patch_count || file.triangleCount !== extras.triangle_count) {
  fail(`${extras.patch_count} patches and ${extras.triangle_count} triangles, the .pvis ${file.patchCount} and ${file.triangleCount}`);
}
for (let i = 0; i < 50; i++) {
  const eye = [Math.cos(i), Math.sin(2.3 * i), Math.cos(0.7 * i)].map((c) => 3 * c);
  const { patches, ranges } = file.query(...eye);
  const merged = [];
  for (const p of patches) {
    const last = merged[merged.length - 1];
    if (last && last[0] + last[1] === firsts[p]) last[1] += firsts[p + 1] - firsts[p];
    else merged.push([firsts[p], firsts[p + 1] - firsts[p]]);
  }
  if (JSON.stringify(merged) !== JSON.stringify(ranges)) fail(`eye ${eye}: ranges ${JSON.stringify(ranges)}, the glTF's ${JSON.stringify(merged)}`);
}
console.log(`${path}: valid glTF 2.0 (${report.issues.numInfos} infos), ${mesh.listPrimitives().length} primitives, UVs and materials kept, patch ranges match the .pvis`);
