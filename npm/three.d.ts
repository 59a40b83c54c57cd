// Types of three.mjs, the three.js helper. Structural: the helper imports nothing from three.js,
// so these name only what it uses of three's objects.
import type { Answer, PvisFile, TriangleRange } from "./patchvis.js";

/** What the helper uses of a `THREE.BufferGeometry`. */
export interface GeometryLike {
  clearGroups(): void;
  addGroup(start: number, count: number, materialIndex?: number): void;
}

/** What the helper uses of a `THREE.Mesh`. */
export interface MeshLike {
  isMesh?: boolean;
  geometry: GeometryLike;
  material: unknown;
}

/** What the helper uses of GLTFLoader's result. */
export interface GltfLike {
  scene: { traverse(callback: (object: any) => void): void };
  parser: { json: any; associations: Map<any, { primitives?: number }> };
}

/** One glTF primitive of the model and its triangles. */
export interface Part<M extends MeshLike = MeshLike> {
  mesh: M;
  first: number;
  count: number;
}

/** A `--mesh-out` model: its parts, patch and triangle counts, each patch's first triangle. */
export interface Model<M extends MeshLike = MeshLike> {
  parts: Part<M>[];
  patchCount: number;
  triangleCount: number;
  patchFirstTriangle: number[];
}

export interface DrawOptions<M extends MeshLike = MeshLike> {
  /** The geometry whose groups are set (default: the part's mesh's). */
  geometry?: (part: Part<M>) => GeometryLike;
  /** The groups' material index (default 0). */
  materialIndex?: number;
  /** Draw the whole model when the eye is inside the innermost shell (default true). */
  drawAllInside?: boolean;
}

/** The model's parts; with `file`, throws unless the glTF and the .pvis are one bake's. */
export function meshParts<M extends MeshLike = MeshLike>(gltf: GltfLike, file?: PvisFile): Model<M>;
/** Sets each part's draw groups to `ranges`; returns the triangles drawn. */
export function setDrawRanges<M extends MeshLike>(parts: Part<M>[], ranges: TriangleRange[], options?: DrawOptions<M>): number;
/** The ranges to draw for `answer`. */
export function drawRanges(model: Model<any>, answer: Answer, options?: { drawAllInside?: boolean }): TriangleRange[];
/** Draws only what `answer` says is visible; returns the triangles drawn. */
export function applyAnswer<M extends MeshLike>(model: Model<M>, answer: Answer, options?: DrawOptions<M>): number;
