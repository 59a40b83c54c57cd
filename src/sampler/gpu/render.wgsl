// ID-buffer rendering of the GPU sampling backend (`mod.rs` describes the technique): one
// draw per view and mesh chunk; `instance_index` picks the view's matrix, every vertex
// carries its patch id, and the fragment writes it to the view's R32Uint layer of the batch.

// Views per batch at most: the size of the matrix array (mod.rs MAX_BATCH_VIEWS).
const MAX_BATCH_VIEWS: u32 = 256u;

// Row-major world (relative to the sphere centre) -> clip matrices of the batch's views.
@group(0) @binding(0) var<uniform> view_matrices: array<mat4x4<f32>, MAX_BATCH_VIEWS>;

struct Varyings {
    @builtin(position) clip: vec4<f32>,
    @location(0) @interpolate(flat) patch_id: u32,
}

@vertex
fn vs_main(
    @location(0) position: vec3<f32>,
    @location(1) patch_id: u32,
    @builtin(instance_index) view: u32,
) -> Varyings {
    var out: Varyings;
    out.clip = vec4<f32>(position, 1.0) * view_matrices[view];
    out.patch_id = patch_id;
    return out;
}

@fragment
fn fs_main(in: Varyings) -> @location(0) u32 {
    return in.patch_id;
}

