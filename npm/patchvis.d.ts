// Types of patchvis.mjs: the .pvis reader compiled to WebAssembly.

/** The reader refused a file; `message` is the reader's own one-line message. */
export class PatchvisError extends Error {
  constructor(message: string, code: number);
  /** The C ABI's status code (negative), or -1 for a query on a closed file. */
  readonly code: number;
}

/** A triangle range `[first, count]` in the baked mesh's triangle order. */
export type TriangleRange = [first: number, count: number];

/** The answer for one eye (spec § Query). */
export interface Answer {
  /** Nearer than the innermost shell's cameras: the answer is approximate; draw everything. */
  insideSphere: boolean;
  /** How many shells the eye is inside: 0 at or beyond the outermost, K + 1 inside the innermost. */
  band: number;
  /** The one or two shells whose rows were joined, outer first. */
  shells: [number, number];
  /** The three views of `shells[0]` whose rows were joined. */
  views: [number, number, number];
  /** The three views of `shells[1]`. */
  innerViews: [number, number, number];
  /** The visible patch ids, ascending. */
  patches: Uint32Array;
  /** The visible patches' triangles, neighbouring ranges merged: one draw each. */
  ranges: TriangleRange[];
}

/** The WebAssembly reader, shared by every file opened through it. */
export class Reader {
  /**
   * Instantiates the reader from the .wasm bytes, a `Response` or a `WebAssembly.Module`;
   * without a source, from the `patchvis.wasm` of this package.
   */
  static load(source?: ArrayBuffer | ArrayBufferView | Response | WebAssembly.Module): Promise<Reader>;
  /** Validates a .pvis file; throws `PatchvisError` with the reader's message if it is refused. */
  open(bytes: Uint8Array | ArrayBuffer): PvisFile;
}

/** An open .pvis file: its bytes live in the reader's memory until `close`. */
export class PvisFile {
  /** Format version. */
  readonly version: number;
  readonly patchCount: number;
  readonly triangleCount: number;
  /** Sphere level and number of stored views of the sampling sphere. */
  readonly level: number;
  readonly views: number;
  /** The patches visible from a camera at (x, y, z) in model space. */
  query(x: number, y: number, z: number): Answer;
  /** Gives the file's memory back to the reader. */
  close(): void;
}

/** The reader's message for a refused file from its parts (kind and values). */
export function errorMessage(kind: number, values: bigint[]): string;

/** An f32 (given by its bits) as Rust's `Display` writes it. */
export function f32Text(bits: number): string;
