// Flat-shaded frame of the evaluator's GPU frame cost (gpu_frame.rs describes the technique):
// positions relative to the sampling-sphere centre, one clip matrix, and the face normal from
// screen-space derivatives of the position, so the vertices need nothing but positions.

// Share of the brightness that does not depend on the normal, so that faces seen edge-on
// stay visible (the CPU pictures, shade.rs, light the same way).
const AMBIENT: f32 = 0.2;

struct Frame {
    // Row-major (relative position, 1) -> clip matrix (sampler/gpu/mod.rs view_matrix).
    clip: mat4x4<f32>,
    // xyz: the camera's forward direction, the light's.
    light: vec4<f32>,
}

@group(0) @binding(0) var<uniform> frame: Frame;

struct Varyings {
    @builtin(position) clip: vec4<f32>,
    @location(0) position: vec3<f32>,
}

@vertex
fn vs_main(@location(0) position: vec3<f32>) -> Varyings {
    var out: Varyings;
    out.clip = vec4<f32>(position, 1.0) * frame.clip;
    out.position = position;
    return out;
}

@fragment
fn fs_main(in: Varyings) -> @location(0) vec4<f32> {
    let normal = normalize(cross(dpdx(in.position), dpdy(in.position)));
    // Both windings are drawn (open meshes show back faces): light either side alike.
    let lambert = abs(dot(normal, frame.light.xyz));
    return vec4<f32>(vec3<f32>(AMBIENT + (1.0 - AMBIENT) * lambert), 1.0);
}
