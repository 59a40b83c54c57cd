// patchvis.mjs: the `.pvis` reader (Rust, no_std, no allocation) compiled to WebAssembly,
// as an ES module for pages and for Node.
//
//   import { Reader } from "./patchvis.mjs";
//   const reader = await Reader.load(wasmBytes);         // bytes, a Response or a Module
//   const file = reader.open(pvisBytes);                  // throws PatchvisError if invalid
//   const { ranges, insideSphere } = file.query(x, y, z); // ranges: [first, count] pairs
//   file.close();
//
// The module is src/capi.rs's C ABI built for wasm32-unknown-unknown (wasm/build.sh): the
// reader validates a file once in `open` and answers queries without allocating. It has no
// allocator of its own, so this wrapper manages the linear memory past `__heap_base`: each
// open file takes one region (its bytes, the 512-byte parsed reader, a streaming state and its
// scratch, the answer), handed out like a stack and given back by `close` (a region closed out of order is
// reused once the regions above it are closed too). Everything is synchronous after `load`.

const FILE_SIZE = 512; // PATCHVIS_FILE_SIZE
const STREAM_SIZE = 8192; // PATCHVIS_STREAM_SIZE
const VISIBLE_SIZE = 32; // sizeof(PatchvisVisible) on wasm32, rounded up
const DETAIL_SIZE = 512; // room for the reader's error message
const PAGE = 65536;

/** The reader refused a file; `message` is the reader's own one-line message. */
export class PatchvisError extends Error {
  constructor(message, code) {
    super(message);
    this.name = "PatchvisError";
    this.code = code;
  }
}

/** The WebAssembly reader, shared by every file opened through it. */
export class Reader {
  /**
   * Instantiates the reader from `source`: the .wasm bytes (ArrayBuffer or typed array), a
   * `Response` (e.g. `fetch("patchvis.wasm")`, compiled while it streams), or a
   * `WebAssembly.Module`.
   */
  static async load(source) {
    let instance;
    if (source instanceof WebAssembly.Module) {
      instance = await WebAssembly.instantiate(source, {});
    } else if (typeof Response !== "undefined" && source instanceof Response) {
      ({ instance } = await WebAssembly.instantiateStreaming(source, {}));
    } else {
      ({ instance } = await WebAssembly.instantiate(source, {}));
    }
    return new Reader(instance);
  }

  constructor(instance) {
    this.exports = instance.exports;
    this.memory = instance.exports.memory;
    const base = Number(instance.exports.__heap_base.value);
    this.base = align(base, 8);
    this.top = this.base; // end of the regions handed out
    this.regions = []; // [{ start, end, open }], in address order
  }

  /**
   * Validates `bytes` (Uint8Array or ArrayBuffer) as a `.pvis` file and returns a `PvisFile`
   * that answers queries. Throws `PatchvisError` with the reader's message if the file is
   * refused; nothing is kept then.
   */
  open(bytes) {
    const data = bytes instanceof Uint8Array ? bytes : new Uint8Array(bytes);
    const start = this.top;
    const dataAt = start;
    const fileAt = align(dataAt + data.length, 8);
    const detailAt = fileAt + FILE_SIZE;
    const parseEnd = detailAt + DETAIL_SIZE;
    this.reserve(parseEnd);
    new Uint8Array(this.memory.buffer, dataAt, data.length).set(data);
    const e = this.exports;
    const rc = e.patchvis_parse(dataAt, data.length, fileAt);
    if (rc !== 0) {
      const n = e.patchvis_error_detail(dataAt, data.length, detailAt, DETAIL_SIZE);
      const text = new TextDecoder().decode(new Uint8Array(this.memory.buffer, detailAt, n));
      throw new PatchvisError(text, rc);
    }
    // Queries go through a streaming state: it keeps the decoded rows of the last answer's
    // path, so a camera that stays in its leaf face costs a few plane tests.
    const words = e.patchvis_stream_scratch_words(fileAt);
    const infoAt = detailAt; // the detail buffer is free again after a parse
    const got = e.patchvis_info(fileAt, infoAt);
    if (got !== 0) throw new PatchvisError(`patchvis_info failed (${got})`, got);
    const patchCount = new DataView(this.memory.buffer).getUint32(infoAt + 4, true);
    const capacity = Math.ceil(patchCount / 2); // merged ranges never exceed this
    const streamAt = parseEnd;
    const scratchAt = streamAt + STREAM_SIZE;
    const eyeAt = scratchAt + 8 * words;
    const outAt = align(eyeAt + 12, 8);
    const countAt = outAt + VISIBLE_SIZE;
    const rangesAt = countAt + 8;
    const end = rangesAt + 8 * capacity;
    this.reserve(end);
    const init = e.patchvis_stream_init(fileAt, scratchAt, words, streamAt);
    if (init !== 0) throw new PatchvisError(`patchvis_stream_init failed (${init})`, init);
    const region = { start, end, open: true };
    this.regions.push(region);
    this.top = end;
    return new PvisFile(this, region, { fileAt, infoAt, streamAt, eyeAt, outAt, countAt, rangesAt, capacity });
  }

  /** Grows the linear memory to hold `end` bytes. */
  reserve(end) {
    const have = this.memory.buffer.byteLength;
    if (end > have) {
      this.memory.grow(Math.ceil((end - have) / PAGE));
    }
  }

  /** Gives back every closed region at the top. */
  release(region) {
    region.open = false;
    while (this.regions.length > 0 && !this.regions[this.regions.length - 1].open) {
      this.top = this.regions.pop().start;
    }
  }
}

/** An open `.pvis` file: its bytes live in the reader's memory until `close`. */
export class PvisFile {
  constructor(reader, region, layout) {
    this.reader = reader;
    this.region = region;
    Object.assign(this, layout);
    // The PatchvisInfo that `open` had patchvis_info write (wasm32 layout): version,
    // patch_count, triangle_count (u64), level, views, ...
    const view = this.view();
    /** Format version of the file. */
    this.version = view.getUint32(this.infoAt, true);
    /** Number of patches. */
    this.patchCount = view.getUint32(this.infoAt + 4, true);
    /** Triangles the patches cover. */
    this.triangleCount = Number(view.getBigUint64(this.infoAt + 8, true));
    /** Sphere level and number of stored views. */
    this.level = view.getUint32(this.infoAt + 16, true);
    this.views = view.getUint32(this.infoAt + 20, true);
  }

  view() {
    return new DataView(this.reader.memory.buffer);
  }

  /**
   * The patches visible from a camera at (x, y, z) in model space (spec § Query):
   * `{ insideSphere, views, patches, ranges }`, where `patches` are the visible patch ids
   * ascending, `ranges` the triangle ranges to draw as `[first, count]` pairs with adjacent
   * ranges merged, `views` the three sphere views whose rows were joined, and `insideSphere`
   * true when the eye is nearer than the sampling cameras (draw everything then). Answered
   * by the streaming reader: while the camera stays in one leaf face of the sampling sphere a
   * query decodes nothing; a move to another leaf decodes only the rows it needs.
   */
  query(x, y, z) {
    if (!this.region.open) throw new PatchvisError("query on a closed file", -1);
    const e = this.reader.exports;
    let view = this.view();
    view.setFloat32(this.eyeAt, x, true);
    view.setFloat32(this.eyeAt + 4, y, true);
    view.setFloat32(this.eyeAt + 8, z, true);
    const rc = e.patchvis_stream_query(this.streamAt, this.eyeAt, this.outAt);
    if (rc !== 0) throw new PatchvisError(`patchvis_stream_query failed (${rc})`, rc);
    view = this.view();
    // PatchvisVisible on wasm32: bits (ptr), words, leaf[3], visible_count, inside_sphere.
    const bitsAt = view.getUint32(this.outAt, true);
    const words = view.getUint32(this.outAt + 4, true);
    const views = [0, 1, 2].map((i) => view.getUint32(this.outAt + 8 + 4 * i, true));
    const count = view.getUint32(this.outAt + 20, true);
    const insideSphere = view.getUint32(this.outAt + 24, true) !== 0;
    const patches = new Uint32Array(count);
    let n = 0;
    for (let w = 0; w < words; w++) {
      for (let half = 0; half < 2; half++) {
        let bits = view.getUint32(bitsAt + 8 * w + 4 * half, true);
        while (bits !== 0) {
          const low = bits & -bits;
          patches[n++] = 64 * w + 32 * half + (31 - Math.clz32(low));
          bits ^= low;
        }
      }
    }
    // The merged ranges in one call (patchvis_ranges).
    e.patchvis_ranges(this.fileAt, this.outAt, this.rangesAt, this.capacity, this.countAt);
    const pairs = view.getUint32(this.countAt, true);
    const flat = new Uint32Array(this.reader.memory.buffer, this.rangesAt, 2 * pairs);
    const ranges = [];
    for (let i = 0; i < pairs; i++) ranges.push([flat[2 * i], flat[2 * i + 1]]);
    return { insideSphere, views, patches, ranges };
  }

  /** Gives the file's memory back to the reader. */
  close() {
    if (this.region.open) this.reader.release(this.region);
  }
}

function align(n, to) {
  return Math.ceil(n / to) * to;
}
