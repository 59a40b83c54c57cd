// Reduction of the GPU sampling backend's ID buffers to per-view patch bitfields (`mod.rs`
// describes the technique): one invocation per pixel of every layer sets (`mark`) or counts
// (`count`) the pixel's patch in that view's row; `threshold` turns counts into bits
// (`--min-pixels`). Only the rows are read back, never the images.

// Empty pixel (the clear value of the id target, mod.rs NO_PATCH); never a patch id.
const NO_PATCH: u32 = 0xffffffffu;

struct ReduceParams {
    // Image side in pixels.
    resolution: u32,
    // Patches (bits per row).
    patches: u32,
    // 32-bit words per row (even, so rows read back as 64-bit words).
    words: u32,
    // `--min-pixels`, for `threshold`.
    min_pixels: u32,
}

@group(0) @binding(0) var ids: texture_2d_array<u32>;
@group(0) @binding(1) var<storage, read_write> bits: array<atomic<u32>>;
@group(0) @binding(2) var<storage, read_write> counts: array<atomic<u32>>;
@group(0) @binding(3) var<uniform> reduce: ReduceParams;

// Side of the square workgroup of the per-pixel passes (mod.rs PIXEL_GROUP).
const PIXEL_GROUP: u32 = 16u;

// Sets bit `id` of the layer's row for the pixel at `g` (x, y, layer).
@compute @workgroup_size(PIXEL_GROUP, PIXEL_GROUP, 1)
fn mark(@builtin(global_invocation_id) g: vec3<u32>) {
    if g.x >= reduce.resolution || g.y >= reduce.resolution {
        return;
    }
    let id = textureLoad(ids, g.xy, g.z, 0).r;
    if id == NO_PATCH {
        return;
    }
    // A patch covers runs of pixels: only the first pixel of a run pays for the atomic.
    if g.x > 0u && textureLoad(ids, vec2<u32>(g.x - 1u, g.y), g.z, 0).r == id {
        return;
    }
    atomicOr(&bits[g.z * reduce.words + id / 32u], 1u << (id % 32u));
}

// Adds the pixel at `g` to its patch's count in the layer's row of counts.
@compute @workgroup_size(PIXEL_GROUP, PIXEL_GROUP, 1)
fn count(@builtin(global_invocation_id) g: vec3<u32>) {
    if g.x >= reduce.resolution || g.y >= reduce.resolution {
        return;
    }
    let id = textureLoad(ids, g.xy, g.z, 0).r;
    if id == NO_PATCH {
        return;
    }
    atomicAdd(&counts[g.z * reduce.patches + id], 1u);
}

// Side of the workgroup of `threshold` (mod.rs WORD_GROUP).
const WORD_GROUP: u32 = 64u;

// Word `g.x` of layer `g.y`'s row: bit `b` set if patch `32 g.x + b` covers at least
// `min_pixels` pixels; resets the counts it read for the next batch.
@compute @workgroup_size(WORD_GROUP, 1, 1)
fn threshold(@builtin(global_invocation_id) g: vec3<u32>) {
    if g.x >= reduce.words {
        return;
    }
    var word = 0u;
    for (var b = 0u; b < 32u; b++) {
        let p = g.x * 32u + b;
        if p < reduce.patches {
            let slot = g.y * reduce.patches + p;
            if atomicLoad(&counts[slot]) >= reduce.min_pixels {
                word |= 1u << b;
            }
            atomicStore(&counts[slot], 0u);
        }
    }
    atomicStore(&bits[g.y * reduce.words + g.x], word);
}
