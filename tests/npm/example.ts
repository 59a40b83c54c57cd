// A short TypeScript user of the installed package: tests/npm/run.sh type-checks it with
// `tsc --noEmit` (it is not run). It uses the reader and the three.js helper as the README
// shows, with stand-ins for three.js's objects (the helper's types are structural).
import { Reader, PatchvisError, type Answer, type PvisFile } from "patchvis";
import { applyAnswer, drawRanges, meshParts, setDrawRanges, type GltfLike, type MeshLike } from "patchvis/three";

async function visibleTriangles(pvis: Uint8Array, eye: [number, number, number]): Promise<number> {
  const reader: Reader = await Reader.load();
  let file: PvisFile;
  try {
    file = reader.open(pvis);
  } catch (e) {
    if (e instanceof PatchvisError) console.error(`refused (${e.code}): ${e.message}`);
    throw e;
  }
  const answer: Answer = file.query(...eye);
  const patches: Uint32Array = answer.patches;
  const triangles = answer.ranges.reduce((sum, [, count]) => sum + count, 0);
  console.log(`${patches.length} of ${file.patchCount} patches, band ${answer.band}`);
  file.close();
  return answer.insideSphere ? -1 : triangles;
}

interface MyMesh extends MeshLike {
  name: string;
}

function draw(gltf: GltfLike, file: PvisFile, eye: [number, number, number]): number {
  const model = meshParts<MyMesh>(gltf, file);
  const answer = file.query(...eye);
  const names: string[] = model.parts.map((part) => part.mesh.name);
  console.log(names, drawRanges(model, answer, { drawAllInside: false }).length);
  setDrawRanges(model.parts, [[0, model.triangleCount]], { materialIndex: 0 });
  return applyAnswer(model, answer);
}

export { draw, visibleTriangles };
