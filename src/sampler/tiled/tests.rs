//! Tests of tiled sampling: bit-identical to brute force on the bunny and on generated meshes
//! (including nested boxes of high depth complexity), options against an independent
//! sequential reference, thread-count independence, checkpoints and resuming.

use super::*;
use crate::progress::NoProgress;
use crate::sampler::conservative::scan_triangle_conservative;
use crate::sampler::raster::{DEFAULT_PATHS, draw_triangle, project, scan_triangle, view_planes};
use crate::sampler::*;
use crate::test_kit::bunny::bunny;
use crate::test_kit::meshes::{noisy_sphere, push_cube};
use crate::test_kit::rng::Rng;
use crate::tiling::{Patch, Tiling, TilingQuality, TilingStats, TriangleMap};

/// A tiling with the given patch of each triangle: bounding spheres around the patch's
/// vertices, and a normal cone from the triangle normals (axis = mean, cosine = the smallest
/// cosine to it, minus a margin).
fn tiling_of(mesh: &Mesh, patch_of: Vec<PatchId>) -> Tiling {
    let count = patch_of.iter().max().map_or(0, |m| m + 1);
    let mut order: Vec<u32> = (0..mesh.triangle_count()).collect();
    order.sort_by_key(|&t| patch_of[t as usize]);
    let mut patches = Vec::new();
    let mut first = 0;
    for p in 0..count {
        let tris: Vec<u32> = order
            .iter()
            .copied()
            .filter(|&t| patch_of[t as usize] == p)
            .collect();
        let points: Vec<[f32; 3]> = tris
            .iter()
            .flat_map(|&t| mesh.triangle(t).map(|v| mesh.position(v)))
            .collect();
        let (lo, hi) = points
            .iter()
            .fold(([f32::MAX; 3], [f32::MIN; 3]), |(lo, hi), q| {
                (
                    std::array::from_fn(|k| lo[k].min(q[k])),
                    std::array::from_fn(|k| hi[k].max(q[k])),
                )
            });
        let center: [f32; 3] = std::array::from_fn(|k| 0.5 * (lo[k] + hi[k]));
        let radius = points
            .iter()
            .map(|q| {
                (0..3)
                    .map(|k| (q[k] - center[k]).powi(2))
                    .sum::<f32>()
                    .sqrt()
            })
            .fold(0.0, f32::max)
            * 1.001
            + 1e-6;
        let normals: Vec<[f32; 3]> = tris
            .iter()
            .map(|&t| {
                let [a, b, c] = mesh.triangle(t).map(|v| mesh.position(v));
                let (u, v) = (
                    [b[0] - a[0], b[1] - a[1], b[2] - a[2]],
                    [c[0] - a[0], c[1] - a[1], c[2] - a[2]],
                );
                crate::sphere::normalize(crate::sphere::cross(u, v))
            })
            .collect();
        let sum = normals
            .iter()
            .fold([0.0; 3], |s, n| crate::sphere::add(s, *n));
        let axis = crate::sphere::normalize(sum);
        let cone_cos = normals
            .iter()
            .map(|n| crate::sphere::dot(*n, axis))
            .fold(1.0, f32::min)
            - 1e-3;
        patches.push(Patch {
            first,
            count: tris.len() as u32,
            area: 1.0,
            center,
            radius,
            cone_axis: axis,
            cone_cos: cone_cos.max(-1.0),
        });
        first += tris.len() as u32;
    }
    Tiling {
        patch_of: TriangleMap::from_vec(patch_of),
        order: TriangleMap::from_vec(order),
        patches,
        stats: TilingStats::default(),
        quality: TilingQuality::default(),
    }
}

fn params_for(mesh: &Mesh, level: u32, resolution: u32) -> SamplingParams {
    SamplingParams::for_mesh(mesh, level, resolution, 50.0)
}

fn tiled(
    mesh: &Mesh,
    tiling: &Tiling,
    p: &SamplingParams,
    o: &SamplingOptions,
) -> VisibilityMatrix {
    sample_tiled(mesh, tiling, p, o, &NoProgress).unwrap()
}

/// [`sample_tiled_split`]'s rows with the probe and before it.
fn tiled_split(
    mesh: &Mesh,
    tiling: &Tiling,
    p: &SamplingParams,
    o: &SamplingOptions,
) -> (VisibilityMatrix, VisibilityMatrix) {
    sample_tiled_split(mesh, tiling, p, o, &NoProgress).unwrap()
}

/// The bunny in 200 patches, sampled at `level` at 64 px: the small setup of most tests.
fn small_bunny(level: u32) -> (Mesh, Tiling, SamplingParams) {
    let mesh = bunny();
    let tiling = crate::tiling::tile(&mesh, 200).unwrap();
    let p = params_for(&mesh, level, 64);
    (mesh, tiling, p)
}

/// `f`, run on a pool of `threads` threads.
fn on_threads<T: Send>(threads: usize, f: impl FnOnce() -> T + Send) -> T {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
        .install(f)
}

fn assert_same(a: &VisibilityMatrix, b: &VisibilityMatrix) {
    assert_eq!((a.views(), a.patches()), (b.views(), b.patches()));
    for v in 0..a.views() {
        assert_eq!(a.row(v), b.row(v), "view {v}");
    }
}

/// A large box holding a 4 × 4 × 4 grid of boxes, each holding a smaller box: seen from any
/// view, most triangles are hidden behind several layers.
fn boxes_in_a_box() -> Mesh {
    let (mut positions, mut triangles) = (Vec::new(), Vec::new());
    push_cube([0.0; 3], 1.0, &mut positions, &mut triangles);
    let mut rng = Rng::new(11);
    for i in 0..4 {
        for j in 0..4 {
            for k in 0..4 {
                let c = [i, j, k].map(|n| -0.75 + 0.5 * n as f32 + 0.05 * rng.signed());
                push_cube(c, 0.2, &mut positions, &mut triangles);
                push_cube(c, 0.1, &mut positions, &mut triangles);
            }
        }
    }
    Mesh::from_memory("boxes", positions, triangles).unwrap()
}

#[test]
fn tiled_equals_brute_force_on_the_bunny() {
    let mesh = bunny();
    let tiling = crate::tiling::tile(&mesh, 300).unwrap();
    let p = params_for(&mesh, 2, 80);
    let brute = sample(&mesh, &tiling.patch_of, 300, &p, &NoProgress);
    assert_same(
        &tiled(&mesh, &tiling, &p, &SamplingOptions::default()),
        &brute,
    );
}

#[test]
fn tiled_equals_brute_force_on_the_bunny_in_small_patches() {
    // About fifty triangles per patch: nearly every section is one cluster, so the tested
    // pass tries the exact rectangle of a section's projected vertices before its triangles.
    let mesh = bunny();
    let tiling = crate::tiling::tile(&mesh, 2000).unwrap();
    let count = tiling.patches.len() as u32;
    let p = params_for(&mesh, 1, 256);
    let brute = sample(&mesh, &tiling.patch_of, count, &p, &NoProgress);
    assert_same(
        &tiled(&mesh, &tiling, &p, &SamplingOptions::default()),
        &brute,
    );
}

#[test]
fn a_tiny_memory_budget_maps_the_mesh_and_changes_nothing() {
    // A 1-byte budget puts the regrouped mesh and the key table in mapped files.
    let (mesh, tiling, p) = small_bunny(2);
    let mapped = SamplingOptions {
        memory: Some(crate::memory::MemoryBudget::new(1).split().sampling),
        ..SamplingOptions::default()
    };
    assert_same(
        &tiled(&mesh, &tiling, &p, &mapped),
        &tiled(&mesh, &tiling, &p, &SamplingOptions::default()),
    );
}

#[test]
fn passes_sharing_a_scene_sample_as_passes_of_their_own() {
    // The passes of a bake in one scene (its set-up built by the first, in a mapped file under
    // a tiny budget, and reused by the next, which would have kept it on the heap): each
    // pass's rows equal a pass sampled alone, on the heap.
    let (mesh, tiling, p) = small_bunny(1);
    let probe = SamplingOptions {
        probe: Some(1),
        ..SamplingOptions::default()
    };
    let passes = [
        SamplingOptions {
            memory: Some(crate::memory::MemoryBudget::new(1).split().sampling),
            ..SamplingOptions::default()
        },
        probe.clone(),
        near(&p, 1.1, probe.clone()),
        near(
            &p,
            2.0,
            SamplingOptions {
                band: Some([p.radius * 1.9, p.radius * 3.0]),
                ..probe
            },
        ),
    ];
    let scene = Scene::new(&mesh, &tiling);
    for options in &passes {
        let shared = sample_scene(&scene, &p, options, &NoProgress).unwrap();
        let alone = SamplingOptions {
            memory: None,
            ..options.clone()
        };
        assert_same(&shared, &tiled(&mesh, &tiling, &p, &alone));
        let (rows, seen) = sample_scene_split(&scene, &p, options, &NoProgress).unwrap();
        let (rows_alone, seen_alone) = tiled_split(&mesh, &tiling, &p, &alone);
        assert_same(&rows, &rows_alone);
        assert_same(&seen, &seen_alone);
    }
}

#[test]
fn tiled_equals_brute_force_on_generated_meshes() {
    let boxes = boxes_in_a_box();
    // Boxes: one patch per face pair, so a patch is a slab of a box; and a greedy tiling.
    let by_pairs = tiling_of(&boxes, (0..boxes.triangle_count()).map(|t| t / 4).collect());
    let sphere = noisy_sphere(30, 60, 0.3, 9);
    // About 0.4 pixel of surface per triangle at 64²: the branch-free loop of `draw_patch`.
    let fine = noisy_sphere(80, 160, 0.3, 5);
    for (mesh, tiling) in [
        (&boxes, by_pairs),
        (&boxes, crate::tiling::tile(&boxes, 40).unwrap()),
        (&sphere, crate::tiling::tile(&sphere, 50).unwrap()),
        (&fine, crate::tiling::tile(&fine, 40).unwrap()),
    ] {
        let p = params_for(mesh, 3, 64);
        let count = tiling.patches.len() as u32;
        let brute = sample(mesh, &tiling.patch_of, count, &p, &NoProgress);
        let fast = tiled(mesh, &tiling, &p, &SamplingOptions::default());
        assert_same(&fast, &brute);
        // The nested boxes are hidden from every view; the outer box is always seen.
        if mesh.triangle_count() == boxes.triangle_count() {
            let seen: u32 = (0..fast.views())
                .map(|v| fast.row(v).iter().map(|w| w.count_ones()).sum::<u32>())
                .max()
                .unwrap();
            assert!(seen < count / 4, "a view sees {seen} of {count} patches");
        }
    }
}

/// The visible patches of one view by a sequential, unculled render into an [`IdBuffer`]
/// (a depth tie kept by the smaller patch): the reference for the options.
fn reference_row(
    mesh: &Mesh,
    patch_of: &[PatchId],
    camera: &Camera,
    conservative: bool,
    min_pixels: u32,
    patches: u32,
) -> Vec<bool> {
    let mut buffer = IdBuffer::new(camera.resolution());
    let planes = view_planes(camera);
    let projected: Vec<_> = (0..mesh.vertex_count())
        .map(|v| project(camera, &planes, mesh.position(v)))
        .collect();
    for t in 0..mesh.triangle_count() {
        let corners = mesh.triangle(t);
        let id = patch_of[t as usize];
        draw_triangle(
            corners.map(|v| projected[v as usize]),
            || corners.map(|v| mesh.position(v)),
            camera,
            &planes,
            |tri| {
                let plot = |i, q, c| buffer.plot(i, q, id, c);
                if conservative {
                    scan_triangle_conservative(tri, camera.resolution(), plot);
                } else {
                    scan_triangle(tri, camera.resolution(), DEFAULT_PATHS, plot);
                }
            },
        );
    }
    let mut counts = vec![0u32; patches as usize];
    for &id in buffer.ids() {
        if id != NO_PATCH {
            counts[id as usize] += 1;
        }
    }
    counts.iter().map(|&c| c >= min_pixels.max(1)).collect()
}

#[test]
fn min_pixels_and_conservative_match_a_sequential_reference() {
    let mesh = noisy_sphere(40, 80, 0.4, 3);
    let tiling = crate::tiling::tile(&mesh, 120).unwrap();
    let p = params_for(&mesh, 2, 48);
    for (conservative, min_pixels) in [(false, 4), (true, 0), (true, 3)] {
        let options = SamplingOptions {
            conservative_raster: conservative,
            min_pixels,
            ..SamplingOptions::default()
        };
        let fast = tiled(&mesh, &tiling, &p, &options);
        let mut differs_from_plain = false;
        let plain = tiled(&mesh, &tiling, &p, &SamplingOptions::default());
        for v in 0..fast.views() {
            let camera = Camera::sampling_view(&p, v);
            let expected = reference_row(
                &mesh,
                &tiling.patch_of,
                &camera,
                conservative,
                min_pixels,
                120,
            );
            for (patch, &e) in expected.iter().enumerate() {
                assert_eq!(
                    fast.get(v, patch as u32),
                    e,
                    "view {v} patch {patch} {options:?}"
                );
            }
            differs_from_plain |= fast.row(v) != plain.row(v);
        }
        assert!(differs_from_plain, "{options:?} changed nothing");
    }
}

#[test]
fn conservative_mode_catches_a_sliver_between_pixel_centres() {
    // A thin triangle in the plane z = 0 seen head-on, narrower than a pixel and lying
    // between two columns of pixel centres: point sampling misses it.
    let positions = vec![[0.013, -0.5, 0.0], [0.016, -0.5, 0.0], [0.0145, 0.5, 0.0]];
    let mesh = Mesh::from_memory("sliver", positions, vec![[0, 1, 2]]).unwrap();
    let camera = Camera::look_at([0.0, 0.0, 3.0], [0.0; 3], 40.0, 32);
    assert_eq!(reference_row(&mesh, &[0], &camera, false, 0, 1), [false]);
    assert_eq!(reference_row(&mesh, &[0], &camera, true, 0, 1), [true]);
}

#[test]
fn dilation_marks_edge_neighbours_that_may_face_the_eye() {
    // A welded unit cube (faces share their edges; faces +X, −X, +Y, −Y, +Z, −Z as
    // patches 0..6, outward winding) around a separate small cube (patch 6).
    let mut positions: Vec<[f32; 3]> = (0..8)
        .map(|i| [i & 1, (i >> 1) & 1, (i >> 2) & 1].map(|b| if b == 1 { 1.0 } else { -1.0 }))
        .collect();
    let quads = [
        [1, 3, 7, 5],
        [0, 4, 6, 2],
        [2, 6, 7, 3],
        [0, 1, 5, 4],
        [4, 5, 7, 6],
        [0, 2, 3, 1],
    ];
    let mut triangles: Vec<[u32; 3]> = quads
        .iter()
        .flat_map(|[a, b, c, d]| [[*a, *b, *c], [*a, *c, *d]])
        .collect();
    push_cube([0.1, -0.05, 0.02], 0.5, &mut positions, &mut triangles);
    let mesh = Mesh::from_memory("cubes", positions, triangles).unwrap();
    let tiling = tiling_of(&mesh, (0..24).map(|t| (t / 2).min(6)).collect());
    let p = SamplingParams {
        level: 0,
        resolution: 64,
        fov_deg: 60.0,
        center: [0.0; 3],
        radius: 3f32.sqrt(),
    };
    let plain = tiled(&mesh, &tiling, &p, &SamplingOptions::default());
    let options = SamplingOptions {
        dilate: true,
        always_visible: vec![6],
        ..SamplingOptions::default()
    };
    let dilated = tiled(&mesh, &tiling, &p, &options);
    for face in 0..6u32 {
        // Level-0 view `face` looks at cube face `face` head-on and sees nothing else.
        let seen: Vec<u32> = (0..7).filter(|&q| plain.get(face, q)).collect();
        assert_eq!(seen, [face]);
        // Dilated: the four faces around it; never the opposite face; patch 6 always.
        let marked: Vec<u32> = (0..7).filter(|&q| dilated.get(face, q)).collect();
        let mut expected: Vec<u32> = (0..6).filter(|&q| q != face ^ 1).collect();
        expected.push(6);
        assert_eq!(marked, expected, "view {face}");
    }
}

#[test]
fn tiled_output_is_identical_for_one_and_two_threads() {
    let mesh = boxes_in_a_box();
    let tiling = crate::tiling::tile(&mesh, 64).unwrap();
    let p = params_for(&mesh, 3, 48);
    for options in [
        SamplingOptions::default(),
        SamplingOptions {
            conservative_raster: true,
            min_pixels: 2,
            dilate: true,
            ..SamplingOptions::default()
        },
        SamplingOptions {
            probe: Some(1),
            ..SamplingOptions::default()
        },
    ] {
        let run = |threads| on_threads(threads, || tiled(&mesh, &tiling, &p, &options));
        assert_same(&run(1), &run(2));
    }
}

/// `probe_reach`: every camera out to it, in any direction, lies in the probe cell of the
/// pass's view nearest its direction (a ball of `CELL_PER_EDGE · edge` around the unit eye),
/// for plain and centroid finer views.
#[test]
fn the_probe_reach_puts_every_camera_out_to_it_in_a_cell() {
    let mut rng = Rng::new(0x2EAC);
    for (level, finer) in [
        (3, FinerViews::Midpoints),
        (5, FinerViews::Midpoints),
        (4, FinerViews::Centroids),
    ] {
        let pass = PassViews::pass(level, finer);
        let reach = probe::probe_reach(&pass);
        let phi = probe::CELL_PER_EDGE * pass.max_seed_angle();
        assert!(reach > 1.0 && reach < 1.0 + phi, "level {level}: {reach}");
        let views: Vec<[f64; 3]> = (0..pass.end())
            .map(|u| pass.direction(u).map(f64::from))
            .collect();
        let mut worst = 0f64;
        for _ in 0..2000 {
            let v = [rng.signed(), rng.signed(), rng.signed()].map(f64::from);
            let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt().max(1e-3);
            let eye = v.map(|x| x / n * reach);
            let nearest = views
                .iter()
                .map(|w| (0..3).map(|k| (eye[k] - w[k]).powi(2)).sum::<f64>().sqrt())
                .fold(f64::INFINITY, f64::min);
            worst = worst.max(nearest);
        }
        assert!(worst <= phi, "level {level}: {worst} > {phi}");
    }
}

#[test]
fn the_probe_pass_keeps_every_row_and_finds_more() {
    // The bunny at 64 px: thin ears, and surfaces turning away at the silhouettes.
    let (mesh, tiling, p) = small_bunny(2);
    let plain = tiled(&mesh, &tiling, &p, &SamplingOptions::default());
    for radius in [0, 1] {
        let probed = tiled(
            &mesh,
            &tiling,
            &p,
            &SamplingOptions {
                probe: Some(radius),
                ..SamplingOptions::default()
            },
        );
        for (a, b) in probed.words().iter().zip(plain.words()) {
            assert_eq!(a & b, *b, "radius {radius}: a probed row lost a patch");
        }
        assert!(probed.count_ones() > plain.count_ones(), "radius {radius}");
        // Back faces behind the silhouettes are left out: far from every patch in every row.
        let all = u64::from(crate::sphere::view_count(p.level)) * 200;
        assert!(
            probed.count_ones() < all * 3 / 4,
            "radius {radius}: {}",
            probed.count_ones()
        );
    }
}

#[test]
fn resume_continues_from_the_checkpoint_and_refuses_a_stale_one() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("out.pvis.ckpt");
    let mesh = noisy_sphere(20, 40, 0.3, 4);
    let tiling = crate::tiling::tile(&mesh, 40).unwrap();
    let p = params_for(&mesh, 2, 32);
    let options = SamplingOptions {
        checkpoint: Some(path.clone()),
        ..SamplingOptions::default()
    };
    let full = tiled(&mesh, &tiling, &p, &options);
    assert_same(
        &full,
        &tiled(&mesh, &tiling, &p, &SamplingOptions::default()),
    );
    // An interrupted bake: levels 0 and 1 done, with a marker in row 0 that only a resumed
    // run keeps (a recomputed row 0 would not have every bit set).
    let hash = checkpoint::input_hash(&mesh, &tiling, &p, &options, false);
    let mut partial = full.clone();
    for patch in 0..partial.patches() {
        partial.set(0, patch);
    }
    checkpoint::save(&path, hash, 2, crate::sphere::view_count(1), &partial).unwrap();
    let resume = SamplingOptions {
        resume: true,
        ..options.clone()
    };
    let resumed = tiled(&mesh, &tiling, &p, &resume);
    assert_eq!(resumed.row(0), partial.row(0));
    for v in 1..full.views() {
        assert_eq!(resumed.row(v), full.row(v), "view {v}");
    }
    // Without --resume the checkpoint is ignored and overwritten.
    assert_same(&tiled(&mesh, &tiling, &p, &options), &full);
    // Other settings: refused.
    let other = SamplingOptions {
        min_pixels: 2,
        ..resume.clone()
    };
    let err = sample_tiled(&mesh, &tiling, &p, &other, &NoProgress).unwrap_err();
    assert!(matches!(err, SamplingError::Checkpoint { .. }), "{err}");
    assert!(err.to_string().contains("stale checkpoint"), "{err}");
    // A damaged file: refused with its size.
    std::fs::write(&path, b"PVISCKPT").unwrap();
    let err = sample_tiled(&mesh, &tiling, &p, &resume, &NoProgress).unwrap_err();
    assert!(
        err.to_string().contains("not a patchvis checkpoint"),
        "{err}"
    );
}

/// A generated model as an in-memory mesh.
fn model_mesh(model: &dyn crate::generate::Model) -> Mesh {
    let (mut positions, mut triangles) = (Vec::new(), Vec::new());
    model
        .vertices(&mut |p| {
            positions.push(p);
            Ok(())
        })
        .unwrap();
    model
        .triangles(&mut |t| {
            triangles.push(t);
            Ok(())
        })
        .unwrap();
    Mesh::from_memory("model", positions, triangles).unwrap()
}

/// A near pass at `factor` bounding radii.
fn near(p: &SamplingParams, factor: f32, options: SamplingOptions) -> SamplingOptions {
    SamplingOptions {
        shell: Some(p.radius * factor),
        ..options
    }
}

/// Checks that the near rows at `factor` bounding radii equal brute force, and that they see
/// more than the sampling views (the eye is nearer and looks every way), but not everything.
fn near_equals_brute_force(mesh: &Mesh, tiling: &Tiling, p: &SamplingParams, factor: f32) {
    let count = tiling.patches.len() as u32;
    let distance = p.radius * factor;
    let brute = sample_near(mesh, &tiling.patch_of, count, p, distance, &NoProgress);
    let fast = tiled(
        mesh,
        tiling,
        p,
        &near(p, factor, SamplingOptions::default()),
    );
    assert_same(&fast, &brute);
    let sampling = tiled(mesh, tiling, p, &SamplingOptions::default());
    assert_ne!(fast.count_ones(), sampling.count_ones(), "{factor}");
    assert!(fast.count_ones() > 0, "{factor}");
}

#[test]
fn near_views_equal_brute_force_on_the_bunny() {
    let (mesh, tiling, p) = small_bunny(1);
    // The bounding sphere itself, a cube map (1.1), the last cube map and the first single
    // camera (1.4, 1.5), one camera (2).
    for factor in [1.0, 1.1, 1.4, 1.5, 2.0] {
        near_equals_brute_force(&mesh, &tiling, &p, factor);
    }
}

#[test]
fn near_views_equal_brute_force_on_thin_parts() {
    // The exposed engine: fins, a perforated plate and narrow gaps, in small patches.
    let mesh = model_mesh(&crate::generate::exposed::ExposedEngine::new(12_000));
    let tiling = crate::tiling::tile(&mesh, 150).unwrap();
    let p = params_for(&mesh, 1, 64);
    for factor in [1.1, 2.0] {
        near_equals_brute_force(&mesh, &tiling, &p, factor);
    }
    // Nested boxes: most patches hidden behind several layers from every eye.
    let boxes = boxes_in_a_box();
    let tiling = crate::tiling::tile(&boxes, 40).unwrap();
    let p = params_for(&boxes, 2, 48);
    near_equals_brute_force(&boxes, &tiling, &p, 1.1);
}

#[test]
fn a_near_view_sees_every_way_from_its_eye() {
    // A ring of 8 boxes around the centre: from an eye just outside the ring's bounding
    // sphere, boxes beside and below the line to the centre lie outside a 90° front face but
    // inside the side faces.
    let (mut positions, mut triangles) = (Vec::new(), Vec::new());
    for k in 0..8 {
        let a = k as f32 * std::f32::consts::FRAC_PI_4;
        push_cube([a.cos(), 0.0, a.sin()], 0.1, &mut positions, &mut triangles);
    }
    let mesh = Mesh::from_memory("ring", positions, triangles).unwrap();
    let tiling = tiling_of(&mesh, (0..96).map(|t| t / 12).collect());
    let p = params_for(&mesh, 0, 64);
    let rows = tiled(
        &mesh,
        &tiling,
        &p,
        &near(&p, 1.05, SamplingOptions::default()),
    );
    let front_only: Vec<u32> = (0..6)
        .map(|v| {
            let camera = near_cameras(&p, crate::sphere::direction(v), p.radius * 1.05)[0];
            reference_row(&mesh, &tiling.patch_of, &camera, false, 0, 8)
                .iter()
                .filter(|&&b| b)
                .count() as u32
        })
        .collect();
    // From above and below (views 2 and 3, ±Y) the front face shows every box; from beside
    // the ring it misses those beside the eye.
    assert_eq!(front_only, [3, 3, 8, 8, 3, 3]);
    for v in 0..6 {
        let seen = rows.row(v)[0].count_ones();
        if front_only[v as usize] == 8 {
            assert_eq!(seen, 8, "view {v}");
        } else {
            // The box beside the eye hides those behind it; the side faces add the two
            // boxes more than 45° off the line to the centre.
            assert_eq!(seen, 5, "view {v}");
        }
    }
}

#[test]
fn near_passes_are_independent_of_threads_shards_and_resuming() {
    let mesh = boxes_in_a_box();
    let tiling = crate::tiling::tile(&mesh, 64).unwrap();
    let p = params_for(&mesh, 2, 40);
    let band = Some([p.radius * 1.1, p.radius * 1.6]);
    for options in [
        near(&p, 1.2, SamplingOptions::default()),
        near(
            &p,
            1.2,
            SamplingOptions {
                conservative_raster: true,
                min_pixels: 2,
                dilate: true,
                always_visible: vec![3],
                ..SamplingOptions::default()
            },
        ),
        near(
            &p,
            1.2,
            SamplingOptions {
                probe: Some(2),
                band,
                ..SamplingOptions::default()
            },
        ),
        near(&p, 2.0, SamplingOptions::default()),
    ] {
        let run = |threads, options: &SamplingOptions| {
            on_threads(threads, || tiled(&mesh, &tiling, &p, options))
        };
        let full = run(1, &options);
        assert_same(&run(2, &options), &full);
        // A shard: its views' rows are the full run's.
        let wanted = vec![5, 17, 40];
        let shard = run(
            2,
            &SamplingOptions {
                views: Some(wanted.clone()),
                ..options.clone()
            },
        );
        for v in wanted {
            assert_eq!(shard.row(v), full.row(v), "view {v} {options:?}");
        }
    }
}

#[test]
fn a_near_checkpoint_resumes_and_refuses_another_shell() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("near.ckpt");
    let mesh = noisy_sphere(20, 40, 0.3, 4);
    let tiling = crate::tiling::tile(&mesh, 40).unwrap();
    let p = params_for(&mesh, 2, 32);
    // With the probe, a resumed run seeds its cameras by the loaded rows, probe included,
    // where a whole run seeds each camera by what the same camera of its seeds showed.
    for probe in [None, Some(1)] {
        let options = near(
            &p,
            1.1,
            SamplingOptions {
                checkpoint: Some(path.clone()),
                probe,
                ..SamplingOptions::default()
            },
        );
        let full = tiled(&mesh, &tiling, &p, &options);
        // Interrupted after level 1, then resumed: the rows of an uninterrupted run.
        let hash = checkpoint::input_hash(&mesh, &tiling, &p, &options, false);
        checkpoint::save(&path, hash, 2, crate::sphere::view_count(1), &full).unwrap();
        let resume = SamplingOptions {
            resume: true,
            ..options.clone()
        };
        assert_same(&tiled(&mesh, &tiling, &p, &resume), &full);
        // Another shell, a band, or the sampling sphere: each another input.
        for other in [
            SamplingOptions {
                shell: Some(p.radius * 1.2),
                ..resume.clone()
            },
            SamplingOptions {
                band: Some([p.radius, p.radius * 1.2]),
                ..resume.clone()
            },
            SamplingOptions {
                shell: None,
                ..resume.clone()
            },
        ] {
            let err = sample_tiled(&mesh, &tiling, &p, &other, &NoProgress).unwrap_err();
            assert!(err.to_string().contains("stale checkpoint"), "{err}");
        }
    }
}

#[test]
fn the_probe_keeps_near_rows_and_a_band_widens_its_cell() {
    let (mesh, tiling, p) = small_bunny(1);
    for factor in [1.1, 2.0] {
        let plain = tiled(
            &mesh,
            &tiling,
            &p,
            &near(&p, factor, SamplingOptions::default()),
        );
        let probe = SamplingOptions {
            probe: Some(2),
            ..SamplingOptions::default()
        };
        let probed = tiled(&mesh, &tiling, &p, &near(&p, factor, probe.clone()));
        let banded = tiled(
            &mesh,
            &tiling,
            &p,
            &near(
                &p,
                factor,
                SamplingOptions {
                    band: Some([p.radius * (factor - 0.05), p.radius * (factor + 0.6)]),
                    ..probe
                },
            ),
        );
        for (a, b) in probed.words().iter().zip(plain.words()) {
            assert_eq!(a & b, *b, "{factor}: a probed row lost a patch");
        }
        for (a, b) in banded.words().iter().zip(probed.words()) {
            assert_eq!(a & b, *b, "{factor}: the band's cell holds the ball's");
        }
        assert!(probed.count_ones() > plain.count_ones(), "{factor}");
        // Back faces behind the silhouettes stay out.
        let all = u64::from(crate::sphere::view_count(p.level)) * 200;
        assert!(
            banded.count_ones() < all * 9 / 10,
            "{factor}: {}",
            banded.count_ones()
        );
    }
}

#[test]
fn a_band_on_the_main_pass_keeps_every_row() {
    // The main pass with shells: its cell spans the band [D_1, D_0] and holds today's ball.
    // A closed model in patches of a few triangles, so that what only the band's nearer
    // cameras face makes whole patches (on the bunny in 200 patches, the parallax its
    // openings are widened by already holds the few it adds).
    let mesh = model_mesh(&crate::generate::exposed::ExposedEngine::new(12_000));
    let tiling = crate::tiling::tile(&mesh, 3000).unwrap();
    let p = params_for(&mesh, 1, 64);
    let probe = SamplingOptions {
        probe: Some(2),
        ..SamplingOptions::default()
    };
    let today = tiled(&mesh, &tiling, &p, &probe);
    let banded = tiled(
        &mesh,
        &tiling,
        &p,
        &SamplingOptions {
            band: Some([p.radius * 1.7, p.distance()]),
            ..probe
        },
    );
    for (a, b) in banded.words().iter().zip(today.words()) {
        assert_eq!(a & b, *b);
    }
    assert!(banded.count_ones() > today.count_ones());
}

#[test]
fn split_sampling_returns_the_probed_rows_and_the_rows_before_the_probe() {
    let dir = tempfile::tempdir().unwrap();
    let (mesh, tiling, p) = small_bunny(1);
    let probe = SamplingOptions {
        probe: Some(2),
        ..SamplingOptions::default()
    };
    for (i, options) in [probe.clone(), near(&p, 1.2, probe)]
        .into_iter()
        .enumerate()
    {
        let plain = SamplingOptions {
            probe: None,
            ..options.clone()
        };
        let split = |options: &SamplingOptions| tiled_split(&mesh, &tiling, &p, options);
        let (rows, seen) = split(&options);
        assert_same(&rows, &tiled(&mesh, &tiling, &p, &options));
        assert_same(&seen, &tiled(&mesh, &tiling, &p, &plain));
        assert!(rows.count_ones() > seen.count_ones(), "{i}");
        // Both go through the checkpoint: a finished one resumes to the same pair, and a
        // plain run refuses it (its rows are not the split run's).
        let checkpoint = SamplingOptions {
            checkpoint: Some(dir.path().join(format!("{i}.ckpt"))),
            ..options
        };
        assert_eq!(split(&checkpoint), (rows.clone(), seen.clone()));
        let resume = SamplingOptions {
            resume: true,
            ..checkpoint
        };
        assert_eq!(split(&resume), (rows, seen));
        let err = sample_tiled(&mesh, &tiling, &p, &resume, &NoProgress).unwrap_err();
        assert!(matches!(err, SamplingError::Checkpoint { .. }), "{err}");
    }
}

#[test]
fn a_probe_leaving_out_what_the_parents_hold_folds_to_the_same_rows() {
    // `folds_into`: the views one level finer than the stored level do not probe the patches
    // their parents hold. The split and cover folds drop those anyway, so their stored rows
    // stay the same bit for bit, on the sampling sphere and on a near pass.
    let (mesh, tiling, p) = small_bunny(2);
    let probe = SamplingOptions {
        probe: Some(1),
        ..SamplingOptions::default()
    };
    for (i, options) in [probe.clone(), near(&p, 1.2, probe)]
        .into_iter()
        .enumerate()
    {
        let split = |options: &SamplingOptions| tiled_split(&mesh, &tiling, &p, options);
        let (rows, seen) = split(&options);
        let leaving_out = SamplingOptions {
            folds_into: Some(1),
            ..options.clone()
        };
        let (lean, lean_seen) = split(&leaving_out);
        assert_same(&lean_seen, &seen);
        let stored = view_count(1);
        for v in 0..rows.views() {
            let (a, b) = (rows.row(v), lean.row(v));
            if v < stored {
                assert_eq!(a, b, "{i}: stored view {v}");
            }
            for (&a, &b) in a.iter().zip(b) {
                assert_eq!(a & b, b, "{i}: view {v} gained a patch");
            }
        }
        assert!(
            lean.count_ones() < rows.count_ones(),
            "{i}: nothing was left out"
        );
        let coarse = |m: &VisibilityMatrix| m.prefix(stored);
        assert_same(
            &split_fold(coarse(&lean), &lean, &seen, 2, 1),
            &split_fold(coarse(&rows), &rows, &seen, 2, 1),
        );
        assert_same(
            &cover_fold(coarse(&lean), &lean, 2, 1),
            &cover_fold(coarse(&rows), &rows, 2, 1),
        );
        // Only the level just finer than the stored one leaves anything out.
        let coarser = SamplingOptions {
            folds_into: Some(0),
            ..options
        };
        assert_same(&split(&coarser).0, &rows);
    }
}

#[test]
fn a_far_shell_sees_what_a_camera_framing_the_model_from_its_distance_sees() {
    let (mesh, tiling, p) = small_bunny(1);
    let factor = 256.0;
    let distance = (f64::from(p.distance()) * factor) as f32;
    let far = tiled(
        &mesh,
        &tiling,
        &p,
        &SamplingOptions {
            shell: Some(distance),
            ..SamplingOptions::default()
        },
    );
    let plain = tiled(&mesh, &tiling, &p, &SamplingOptions::default());
    // The sampling sphere whose field of view frames the bounding sphere from that distance.
    let framed = SamplingParams {
        fov_deg: (2.0
            * (f64::from(p.radius) / f64::from(distance))
                .asin()
                .to_degrees()) as f32,
        ..p
    };
    let seen_far = tiled(&mesh, &tiling, &framed, &SamplingOptions::default());
    let (mut far_bits, mut agree, mut beyond) = (0u32, 0u32, 0u32);
    for v in 0..plain.views() {
        for ((a, b), c) in far.row(v).iter().zip(plain.row(v)).zip(seen_far.row(v)) {
            far_bits += a.count_ones();
            agree += (a & c).count_ones();
            // The rim that a camera at the sampling distance sees past.
            beyond += (a & !b).count_ones();
        }
    }
    // The two far cameras differ in the last bits of their placement only.
    assert!(agree * 100 >= far_bits * 99, "{agree} of {far_bits}");
    assert!(beyond > 0, "the far shell adds no rim");
}

#[test]
fn centroid_views_render_each_face_centre_exactly_whatever_the_threads_or_shards() {
    // `finer: Centroids`: level 2's slots beyond level 1's are level 1's face centroids.
    // Each renders what a brute-force render from its direction shows, the stored prefix is
    // the level-1 views', the slots after the last face stay empty, and threads and shards
    // change no row.
    let (mesh, tiling, p) = small_bunny(2);
    let centroids = SamplingOptions {
        finer: FinerViews::Centroids,
        ..SamplingOptions::default()
    };
    let run = |threads, options: &SamplingOptions| {
        on_threads(threads, || tiled(&mesh, &tiling, &p, options))
    };
    let rows = run(1, &centroids);
    assert_eq!(rows.views(), view_count(2));
    let plain = tiled(&mesh, &tiling, &p, &SamplingOptions::default());
    assert_same(&rows.prefix(view_count(1)), &plain.prefix(view_count(1)));
    let pass = PassViews::pass(2, FinerViews::Centroids);
    let patches = tiling.patches.len() as u32;
    for u in pass.finer_range() {
        let camera = Camera::sampling(&p, pass.direction(u));
        let expected = reference_row(&mesh, &tiling.patch_of, &camera, false, 0, patches);
        let got: Vec<bool> = (0..patches).map(|q| rows.get(u, q)).collect();
        assert_eq!(got, expected, "centroid view {u}");
    }
    for u in pass.end()..rows.views() {
        assert!(rows.row(u).iter().all(|&w| w == 0), "slot {u} is no view");
    }
    let probed = SamplingOptions {
        probe: Some(1),
        folds_into: Some(1),
        ..centroids.clone()
    };
    for options in [centroids, probed] {
        let full = run(1, &options);
        assert_same(&run(2, &options), &full);
        // A shard wanting a centroid, a stored view and a slot that names no view.
        let wanted = vec![7, view_count(1) + 5, pass.end() + 1];
        let shard = run(
            2,
            &SamplingOptions {
                views: Some(wanted.clone()),
                ..options.clone()
            },
        );
        for v in wanted {
            assert_eq!(shard.row(v), full.row(v), "view {v} {options:?}");
        }
        // A centroid, its face's three corners and their ancestors.
        let u = view_count(1) + 5;
        let mut needed = std::collections::BTreeSet::from([u]);
        let mut todo: Vec<u32> = pass.seeds(u).views().to_vec();
        while let Some(v) = todo.pop() {
            if needed.insert(v) {
                todo.extend(crate::sphere::parents(v).into_iter().flatten());
            }
        }
        assert_eq!(rendered_view_count(&pass, &[u]), needed.len() as u32);
    }
}

#[test]
fn a_near_pass_puts_its_cameras_at_the_centroids_too() {
    // A shell's centroid views: each row is the OR of brute-force renders of the near cameras
    // looking out from its face's centre (a cube map at 1.1 radii), not from the sphere vertex
    // its slot would name in a vertex pass.
    let (mesh, tiling, p) = small_bunny(2);
    let options = near(
        &p,
        1.1,
        SamplingOptions {
            finer: FinerViews::Centroids,
            ..SamplingOptions::default()
        },
    );
    let rows = tiled(&mesh, &tiling, &p, &options);
    let pass = PassViews::pass(2, FinerViews::Centroids);
    let patches = tiling.patches.len() as u32;
    let vertices = sample_near(
        &mesh,
        &tiling.patch_of,
        patches,
        &p,
        p.radius * 1.1,
        &NoProgress,
    );
    let mut differs = false;
    for u in pass.finer_range() {
        let mut expected = vec![false; patches as usize];
        for camera in near_cameras(&p, pass.direction(u), p.radius * 1.1).iter() {
            let row = reference_row(&mesh, &tiling.patch_of, camera, false, 0, patches);
            expected.iter_mut().zip(row).for_each(|(e, r)| *e |= r);
        }
        let got: Vec<bool> = (0..patches).map(|q| rows.get(u, q)).collect();
        assert_eq!(got, expected, "centroid view {u}");
        differs |= rows.row(u) != vertices.row(u);
    }
    assert!(
        differs,
        "the centroids saw what the vertices of their slots see"
    );
}

#[test]
fn a_centroid_probe_leaving_out_what_the_corners_hold_folds_to_the_same_rows() {
    // A centroid's seeds are its face's corners, which are its fold targets: its probe may
    // leave out what they hold and the split and cover folds stay the same bit for bit.
    let (mesh, tiling, p) = small_bunny(2);
    let options = SamplingOptions {
        probe: Some(1),
        finer: FinerViews::Centroids,
        ..SamplingOptions::default()
    };
    let (rows, seen) = tiled_split(&mesh, &tiling, &p, &options);
    let (lean, lean_seen) = tiled_split(
        &mesh,
        &tiling,
        &p,
        &SamplingOptions {
            folds_into: Some(1),
            ..options
        },
    );
    assert_same(&lean_seen, &seen);
    assert!(
        lean.count_ones() < rows.count_ones(),
        "nothing was left out"
    );
    let pass = PassViews::new(1, 2, FinerViews::Centroids);
    let coarse = |m: &VisibilityMatrix| m.prefix(view_count(1));
    assert_same(
        &split_fold_views(coarse(&lean), &lean, &seen, &pass),
        &split_fold_views(coarse(&rows), &rows, &seen, &pass),
    );
    assert_same(
        &fold_views(coarse(&lean), &lean, &pass, FoldCorners::Cover),
        &fold_views(coarse(&rows), &rows, &pass, FoldCorners::Cover),
    );
}
