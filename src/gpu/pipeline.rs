//! What the GPU's renders share: the clip matrix of a sampling camera (reversed Z) and the
//! depth-tested pipeline that draws triangle lists with both windings, used by the sampler's
//! ID buffers and the evaluator's timed frames alike.

use crate::sampler::Camera;

/// The clip matrix of `camera` for positions relative to `center`, row-major (`clip = M ·
/// (p − center, 1)`): `x` and `y` are [`Camera::clip`]'s, rescaled to normalised device
/// coordinates (`x / w` in `[−1, 1]` across the image, `y` up), `z = near` so that the depth
/// `near / w` is 1 on the near plane and falls towards 0 far away (reversed Z, which keeps
/// `f32` depth precise), and `w` is the view-space depth. Computed in `f64` from the camera's
/// basis and eye relative to `center`, then rounded once.
pub fn view_matrix(camera: &Camera, center: [f32; 3]) -> [f32; 16] {
    let eye = camera.eye();
    let e = [
        eye[0] - f64::from(center[0]),
        eye[1] - f64::from(center[1]),
        eye[2] - f64::from(center[2]),
    ];
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    // Pixels per unit of x / w over half the image: 1 / tan(fov / 2).
    let k = 1.0 / (camera.fov_deg().to_radians() * 0.5).tan();
    let (r, u, f) = (camera.right(), camera.up(), camera.forward());
    let rows: [[f64; 4]; 4] = [
        [k * r[0], k * r[1], k * r[2], -k * dot(e, r)],
        [k * u[0], k * u[1], k * u[2], -k * dot(e, u)],
        [0.0, 0.0, 0.0, camera.near()],
        [f[0], f[1], f[2], -dot(e, f)],
    ];
    let mut out = [0.0f32; 16];
    for (i, value) in rows.iter().flatten().enumerate() {
        out[i] = *value as f32;
    }
    out
}

/// A render pipeline over triangle lists with both windings drawn (as on the CPU: a back face
/// can be the visible one on an open or inconsistently wound mesh), reversed-Z depth
/// (`Depth32Float`, larger is nearer) tested and written, and one colour target of `format`;
/// the shader's entry points are `vs_main` and `fs_main`. The sampler's ID buffers and the
/// evaluator's timed frames both draw this way.
pub(crate) fn depth_tested_pipeline(
    device: &wgpu::Device,
    label: &str,
    layout: &wgpu::PipelineLayout,
    module: &wgpu::ShaderModule,
    vertices: wgpu::VertexBufferLayout<'_>,
    format: wgpu::TextureFormat,
) -> wgpu::RenderPipeline {
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some(label),
        layout: Some(layout),
        vertex: wgpu::VertexState {
            module,
            entry_point: Some("vs_main"),
            compilation_options: Default::default(),
            buffers: &[Some(vertices)],
        },
        primitive: wgpu::PrimitiveState {
            topology: wgpu::PrimitiveTopology::TriangleList,
            cull_mode: None,
            ..Default::default()
        },
        depth_stencil: Some(wgpu::DepthStencilState {
            format: wgpu::TextureFormat::Depth32Float,
            depth_write_enabled: Some(true),
            depth_compare: Some(wgpu::CompareFunction::Greater),
            stencil: Default::default(),
            bias: Default::default(),
        }),
        multisample: Default::default(),
        fragment: Some(wgpu::FragmentState {
            module,
            entry_point: Some("fs_main"),
            compilation_options: Default::default(),
            targets: &[Some(wgpu::ColorTargetState {
                format,
                blend: None,
                write_mask: wgpu::ColorWrites::ALL,
            })],
        }),
        multiview_mask: None,
        cache: None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampler::SamplingParams;
    use crate::sphere::view_count;

    /// The clip matrix puts every point where the CPU camera does: pixel
    /// `((x/w + 1) · res/2, (1 − y/w) · res/2)` equals [`Camera::project`], and the depth
    /// `near / w` is 1 on the near plane.
    #[test]
    fn view_matrix_projects_like_the_cpu_camera() {
        let params = SamplingParams {
            level: 2,
            resolution: 512,
            fov_deg: 45.0,
            center: [1000.0, -20.0, 3.5],
            radius: 2.0,
        };
        let half = f64::from(params.resolution) / 2.0;
        for view in 0..view_count(params.level) {
            let camera = Camera::sampling_view(&params, view);
            let m = view_matrix(&camera, params.center).map(f64::from);
            for k in 0..50 {
                let t = f64::from(k) * 0.37;
                let offset = [t.sin() * 1.5, (2.0 * t).cos() * 1.5, (3.0 * t).sin() * 1.2];
                let p: [f32; 3] = std::array::from_fn(|i| params.center[i] + offset[i] as f32);
                let rel: [f64; 3] =
                    std::array::from_fn(|i| f64::from(p[i]) - f64::from(params.center[i]));
                let row = |r: usize| {
                    m[4 * r] * rel[0] + m[4 * r + 1] * rel[1] + m[4 * r + 2] * rel[2] + m[4 * r + 3]
                };
                let (x, y, w) = (row(0), row(1), row(3));
                let [px, py] = camera.project(p).expect("in front of the camera");
                let (gx, gy) = ((x / w + 1.0) * half, (1.0 - y / w) * half);
                // f32 matrix entries: agreement to a few thousandths of a pixel.
                assert!(
                    (gx - px).abs() < 2e-3 && (gy - py).abs() < 2e-3,
                    "view {view}: GPU ({gx}, {gy}), CPU ({px}, {py})"
                );
            }
            // On the near plane the depth is 1.
            let f = camera.forward();
            let e = camera.eye();
            let on_near: [f64; 3] =
                std::array::from_fn(|i| e[i] + f[i] * camera.near() - f64::from(params.center[i]));
            let w = m[12] * on_near[0] + m[13] * on_near[1] + m[14] * on_near[2] + m[15];
            assert!(
                (m[11] / w - 1.0).abs() < 1e-3,
                "view {view}: depth {}",
                m[11] / w
            );
        }
    }
}
