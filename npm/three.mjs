// patchvis/three: draws only the triangles a patchvis answer names, on a mesh baked with
// `patchvis bake --mesh-out X.glb` and loaded with three.js's GLTFLoader.
//
//   import { Reader } from "patchvis";
//   import { meshParts, applyAnswer } from "patchvis/three";
//   const gltf = await new GLTFLoader().loadAsync("model.glb");
//   const file = (await Reader.load()).open(pvisBytes);
//   const model = meshParts(gltf, file);       // checks the .glb and the .pvis are one bake's
//   scene.add(gltf.scene);
//   // each frame, or when the camera moved:
//   applyAnswer(model, file.query(camera.position.x, camera.position.y, camera.position.z));
//
// Why it works: the .glb's triangles are in the .pvis file's patch order, so an answer's
// ranges [first, count] are ranges of the one index buffer; each glTF primitive (a run of one
// material) covers the triangles [first_triangle, first_triangle + triangle_count) that its
// extras.patchvis names, and a range becomes a draw group of each primitive it overlaps.
// three.js draws a mesh's groups only when its material is an array, so `meshParts` wraps
// each material in one. The helper imports nothing: it works on the objects three.js hands it.

/**
 * The drawable parts of a `--mesh-out` glTF as GLTFLoader returns it (`gltf`): one per glTF
 * primitive, `{ mesh, first, count }` with its triangle range, plus the model's
 * `patchCount`, `triangleCount` and `patchFirstTriangle` (each patch's first triangle, and
 * the triangle count last). With `file` (an open `PvisFile`), throws unless both come from
 * one bake. Each mesh's material becomes a one-element array (see above).
 */
export function meshParts(gltf, file) {
  const meshDef = gltf.parser.json.meshes?.[0];
  const extras = meshDef?.extras?.patchvis;
  if (!extras) {
    throw new Error("the glTF has no extras.patchvis: make it with patchvis bake --mesh-out X.glb");
  }
  if (file && (extras.triangle_count !== file.triangleCount || extras.patch_count !== file.patchCount)) {
    throw new Error(
      `the glTF has ${extras.patch_count} patches and ${extras.triangle_count} triangles, ` +
        `the .pvis ${file.patchCount} and ${file.triangleCount}: use the pair one bake wrote`,
    );
  }
  const parts = [];
  gltf.scene.traverse((object) => {
    if (!object.isMesh) return;
    const where = gltf.parser.associations.get(object);
    const primitive = meshDef.primitives[where?.primitives ?? 0];
    const { first_triangle: first, triangle_count: count } = primitive.extras.patchvis;
    if (!Array.isArray(object.material)) object.material = [object.material];
    parts.push({ mesh: object, first, count });
  });
  return {
    parts,
    patchCount: extras.patch_count,
    triangleCount: extras.triangle_count,
    patchFirstTriangle: extras.patch_first_triangle,
  };
}

/**
 * Sets each part's draw groups to the triangles of `ranges` (`[first, count]` pairs in the
 * model's triangle order, ascending, as a query returns them) that fall in it; returns the
 * triangles drawn. `geometry(part)` picks the geometry to set (default the part's mesh's);
 * `materialIndex` is the groups' material (default 0).
 */
export function setDrawRanges(parts, ranges, { geometry = (part) => part.mesh.geometry, materialIndex = 0 } = {}) {
  let drawn = 0;
  for (const part of parts) {
    const g = geometry(part);
    g.clearGroups();
    const end = part.first + part.count;
    for (const [first, count] of ranges) {
      const a = Math.max(first, part.first);
      const b = Math.min(first + count, end);
      if (a < b) {
        g.addGroup(3 * (a - part.first), 3 * (b - a), materialIndex);
        drawn += b - a;
      }
    }
  }
  return drawn;
}

/**
 * The ranges to draw for `answer` (what `PvisFile.query` returns): its ranges, or the whole
 * model when the eye is inside the innermost sampling shell (`insideSphere`, where the answer
 * is only an approximation) unless `drawAllInside` is false.
 */
export function drawRanges(model, answer, { drawAllInside = true } = {}) {
  return drawAllInside && answer.insideSphere ? [[0, model.triangleCount]] : answer.ranges;
}

/**
 * `setDrawRanges(model.parts, drawRanges(model, answer, options), options)`: draws only what
 * `answer` says is visible; returns the triangles drawn.
 */
export function applyAnswer(model, answer, options = {}) {
  return setDrawRanges(model.parts, drawRanges(model, answer, options), options);
}
