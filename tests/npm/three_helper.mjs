// The three.js helper (`patchvis/three`) on stand-ins for GLTFLoader's result: a two-primitive
// --mesh-out model of 10 triangles in 3 patches. Checks the parts meshParts lists, the draw
// groups applyAnswer sets (ranges split at the primitives' boundaries, everything inside the
// innermost shell) and the refusal of a .pvis of another bake. Run by tests/npm/run.sh from
// the folder the package is installed in, so that `patchvis/three` is the installed copy.
import assert from "node:assert/strict";
import { applyAnswer, meshParts } from "patchvis/three";

function geometry() {
  return { groups: [], clearGroups() { this.groups = []; }, addGroup(start, count, m) { this.groups.push([start, count, m]); } };
}
const meshes = [0, 1].map((primitives) => ({ isMesh: true, material: { name: `m${primitives}` }, geometry: geometry(), primitives }));
const gltf = {
  scene: { traverse: (f) => [{ isMesh: false }, ...meshes].forEach(f) },
  parser: {
    associations: new Map(meshes.map((m) => [m, { primitives: m.primitives }])),
    json: {
      meshes: [{
        extras: { patchvis: { patch_count: 3, triangle_count: 10, patch_first_triangle: [0, 4, 7, 10] } },
        primitives: [{ extras: { patchvis: { first_triangle: 0, triangle_count: 6 } } }, { extras: { patchvis: { first_triangle: 6, triangle_count: 4 } } }],
      }],
    },
  },
};
const model = meshParts(gltf, { patchCount: 3, triangleCount: 10 });
assert.deepEqual(model.parts.map(({ first, count }) => [first, count]), [[0, 6], [6, 4]]);
assert.deepEqual(model.patchFirstTriangle, [0, 4, 7, 10]);
assert.ok(meshes.every((m) => Array.isArray(m.material) && m.material.length === 1));
// Patches 0 and 2: triangles 0..4 and 7..10; the second range starts one triangle into part 1.
assert.equal(applyAnswer(model, { insideSphere: false, ranges: [[0, 4], [7, 3]] }), 7);
assert.deepEqual(meshes[0].geometry.groups, [[0, 12, 0]]);
assert.deepEqual(meshes[1].geometry.groups, [[3, 9, 0]]);
// Inside the innermost shell: everything.
assert.equal(applyAnswer(model, { insideSphere: true, ranges: [] }), 10);
assert.deepEqual(meshes[1].geometry.groups, [[0, 12, 0]]);
assert.throws(() => meshParts(gltf, { patchCount: 4, triangleCount: 10 }), /use the pair one bake wrote/);
console.log("patchvis/three: parts, draw groups and the one-bake check on a stand-in model");
