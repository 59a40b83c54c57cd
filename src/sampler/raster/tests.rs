use super::*;
use crate::sampler::NO_PATCH;
use crate::test_kit::meshes::{fan, square_grid};
use crate::test_kit::rng::Rng;
use proptest::prelude::*;

const ALWAYS_SPANS: ScanPaths = ScanPaths {
    tiny: false,
    span_min_width: 0,
};
const NEVER_SPANS: ScanPaths = ScanPaths {
    tiny: false,
    span_min_width: i64::MAX,
};
const ALL_PATHS: [ScanPaths; 3] = [DEFAULT_PATHS, ALWAYS_SPANS, NEVER_SPANS];

fn vertex(x: f64, y: f64) -> ScreenVertex {
    ScreenVertex {
        x: (x * SUBPIXEL as f64) as i32,
        y: (y * SUBPIXEL as f64) as i32,
        q: 1.0,
    }
}

fn screen_counts(tris: &[[ScreenVertex; 3]], resolution: u32, paths: ScanPaths) -> Vec<u32> {
    let mut counts = vec![0; (resolution * resolution) as usize];
    for &tri in tris {
        scan_triangle(tri, resolution, paths, |i, _, covered| {
            counts[i] += u32::from(covered)
        });
    }
    counts
}

#[test]
fn shared_diagonal_through_pixel_centres_is_owned_once() {
    // Corners on pixel corners, the diagonal y = x through the centres (k + 0.5, k + 0.5).
    let (a, b, c, d) = (
        vertex(2.0, 2.0),
        vertex(10.0, 2.0),
        vertex(10.0, 10.0),
        vertex(2.0, 10.0),
    );
    for tris in [[[a, b, c], [a, c, d]], [[c, a, d], [b, a, c]]] {
        for span in ALL_PATHS {
            let counts = screen_counts(&tris, 12, span);
            for y in 0..12 {
                for x in 0..12 {
                    let expected = u32::from((2..10).contains(&x) && (2..10).contains(&y));
                    assert_eq!(counts[y * 12 + x], expected, "pixel ({x}, {y})");
                }
            }
        }
    }
}

#[test]
fn top_left_rule_keeps_top_and_left_edges_through_centres() {
    // A square whose edges run through pixel centres: the top row and left column are kept,
    // the bottom row and right column belong to the neighbours.
    let (a, b, c, d) = (
        vertex(2.5, 2.5),
        vertex(10.5, 2.5),
        vertex(10.5, 10.5),
        vertex(2.5, 10.5),
    );
    for tris in [[[a, b, c], [a, c, d]], [[a, b, d], [b, c, d]]] {
        for span in ALL_PATHS {
            let counts = screen_counts(&tris, 12, span);
            for y in 0..12 {
                for x in 0..12 {
                    let expected = u32::from((2..10).contains(&x) && (2..10).contains(&y));
                    assert_eq!(counts[y * 12 + x], expected, "pixel ({x}, {y})");
                }
            }
        }
    }
}

#[test]
fn degenerate_and_centre_free_triangles_draw_nothing() {
    let line = [vertex(1.0, 1.0), vertex(5.0, 5.0), vertex(9.0, 9.0)];
    let sliver = [vertex(1.6, 1.6), vertex(2.4, 1.6), vertex(2.0, 2.4)];
    assert!(
        screen_counts(&[line, sliver], 12, NEVER_SPANS)
            .iter()
            .all(|&c| c == 0)
    );
}

/// Signed distance of `p` from the line `a → b`, in the units of the coordinates.
fn side(a: [f64; 2], b: [f64; 2], p: [f64; 2]) -> f64 {
    let (ex, ey) = (b[0] - a[0], b[1] - a[1]);
    (ex * (p[1] - a[1]) - ey * (p[0] - a[0])) / (ex * ex + ey * ey).sqrt()
}

/// Checks coverage against a convex polygon: pixels whose centre is inside by more than
/// `margin` pixels are covered exactly once, those outside by more than it never.
fn assert_covers_polygon_once(counts: &[u32], resolution: u32, polygon: &[[f64; 2]]) {
    let margin = 0.01;
    let area: f64 = (0..polygon.len())
        .map(|i| {
            let (p, q) = (polygon[i], polygon[(i + 1) % polygon.len()]);
            p[0] * q[1] - p[1] * q[0]
        })
        .sum();
    let orientation = area.signum();
    let (mut inside, mut outside) = (0, 0);
    for y in 0..resolution {
        for x in 0..resolution {
            let centre = [x as f64 + 0.5, y as f64 + 0.5];
            let nearest = (0..polygon.len())
                .map(|i| orientation * side(polygon[i], polygon[(i + 1) % polygon.len()], centre))
                .fold(f64::MAX, f64::min);
            let count = counts[(y * resolution + x) as usize];
            if nearest > margin {
                assert_eq!(count, 1, "inside pixel ({x}, {y})");
                inside += 1;
            } else if nearest < -margin {
                assert_eq!(count, 0, "outside pixel ({x}, {y})");
                outside += 1;
            }
        }
    }
    assert!(
        inside > 100 && outside > 100,
        "{inside} inside, {outside} outside"
    );
}

#[test]
fn jittered_grid_is_watertight_from_odd_viewpoints() {
    let mesh = square_grid(23, 0.3, 7, |u, v| [u, v, 0.0]);
    let eyes = [
        [0.013, -0.021, 3.0],
        [0.7, 0.4, 2.5],
        [-1.9, 0.33, 1.1],
        [0.2, -2.7, 0.9],
    ];
    for (k, eye) in eyes.into_iter().enumerate() {
        let resolution = 97 + 2 * k as u32;
        let camera = Camera::look_at(eye, [0.05, -0.03, 0.0], 47.0, resolution);
        let counts = coverage_counts(&mesh, &camera);
        let corners = [[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]]
            .map(|[u, v]| camera.project([u, v, 0.0]).unwrap());
        assert_covers_polygon_once(&counts, resolution, &corners);
    }
}

#[test]
fn fan_around_a_centre_vertex_is_watertight() {
    let mesh = fan(37, 3);
    let camera = Camera::look_at([0.031, 0.017, 2.2], [0.0, 0.0, 0.0], 60.0, 101);
    let counts = coverage_counts(&mesh, &camera);
    let rim: Vec<[f64; 2]> = (1..mesh.vertex_count())
        .map(|v| camera.project(mesh.position(v)).unwrap())
        .collect();
    assert_covers_polygon_once(&counts, 101, &rim);
}

#[test]
fn large_floor_crossing_the_near_plane_covers_the_lower_half() {
    // A 200 × 200 floor one unit under an eye looking at the horizon: its far edge projects
    // to y = 32.32, so rows 32.. are covered and rows ..32 are sky.
    let positions = vec![
        [-100.0, 0.0, -100.0],
        [100.0, 0.0, -100.0],
        [100.0, 0.0, 100.0],
        [-100.0, 0.0, 100.0],
    ];
    let mesh = Mesh::from_memory("floor", positions, vec![[0, 1, 2], [0, 2, 3]]).unwrap();
    let camera = Camera::look_at([0.0, 1.0, 0.0], [0.0, 1.0, -1.0], 90.0, 64);
    let mut buffer = IdBuffer::new(64);
    render_ids(&mesh, &[4, 5], &camera, &mut buffer);
    for (i, &id) in buffer.ids().iter().enumerate() {
        let y = i / 64;
        if y < 32 {
            assert_eq!(id, NO_PATCH, "pixel {i}");
        } else {
            assert!(id == 4 || id == 5, "pixel {i}");
        }
    }
    let counts = coverage_counts(&mesh, &camera);
    assert!(counts[32 * 64..].iter().all(|&c| c == 1));
}

#[test]
fn floor_grid_clipped_at_the_near_plane_stays_watertight() {
    let half = 10.0;
    let mesh = square_grid(40, 0.2, 11, |u, v| [u * half, 0.0, v * half]);
    let eye = [0.1f32, 0.5, 0.3];
    let camera = Camera::look_at(eye, [0.3, 0.2, -2.0], 70.0, 64);
    let counts = coverage_counts(&mesh, &camera);
    let scale = 32.0 / (35f64.to_radians()).tan();
    let (f, r, u) = (camera.forward(), camera.right(), camera.up());
    let (mut covered, mut empty) = (0, 0);
    for y in 0..64 {
        for x in 0..64 {
            let (dx, dy) = (
                (x as f64 + 0.5 - 32.0) / scale,
                (y as f64 + 0.5 - 32.0) / scale,
            );
            let dir: [f64; 3] = std::array::from_fn(|i| f[i] + r[i] * dx - u[i] * dy);
            let count = counts[y * 64 + x];
            if dir[1] >= 0.0 {
                assert_eq!(count, 0, "sky pixel ({x}, {y})");
                continue;
            }
            let t = -eye[1] as f64 / dir[1];
            let hit = [eye[0] as f64 + t * dir[0], eye[2] as f64 + t * dir[2]];
            let inside = hit
                .iter()
                .map(|c| half as f64 - c.abs())
                .fold(f64::MAX, f64::min);
            if inside > 0.05 {
                assert_eq!(count, 1, "floor pixel ({x}, {y})");
                covered += 1;
            } else if inside < -0.05 {
                assert_eq!(count, 0, "pixel beyond the floor ({x}, {y})");
                empty += 1;
            }
        }
    }
    assert!(covered > 1000 && empty > 100, "{covered} {empty}");
}

fn two_quads(near_first: bool) -> (Mesh, Vec<PatchId>) {
    let far = [
        [-1.0, -1.0, 0.0],
        [1.0, -1.0, 0.0],
        [1.0, 1.0, 0.0],
        [-1.0, 1.0, 0.0],
    ];
    let near = far.map(|[x, y, _]| [x + 0.5, y + 0.5, 0.5]);
    let (first, second, ids) = if near_first {
        (near, far, vec![1, 1, 0, 0])
    } else {
        (far, near, vec![0, 0, 1, 1])
    };
    let positions = first.into_iter().chain(second).collect();
    let triangles = vec![[0, 1, 2], [0, 2, 3], [4, 5, 6], [4, 6, 7]];
    (
        Mesh::from_memory("quads", positions, triangles).unwrap(),
        ids,
    )
}

#[test]
fn nearer_quad_wins_in_either_order() {
    let camera = Camera::look_at([0.1, 0.05, 4.0], [0.0, 0.0, 0.0], 60.0, 64);
    let mut buffers = [true, false].map(|near_first| {
        let (mesh, ids) = two_quads(near_first);
        let mut buffer = IdBuffer::new(64);
        render_ids(&mesh, &ids, &camera, &mut buffer);
        buffer
    });
    assert_eq!(buffers[0].ids(), buffers[1].ids());
    let pixel = |p: [f32; 3]| {
        let [x, y] = camera.project(p).unwrap();
        y as usize * 64 + x as usize
    };
    assert_eq!(buffers[0].ids()[pixel([0.25, 0.25, 0.5])], 1);
    assert_eq!(buffers[0].ids()[pixel([-0.75, -0.75, 0.0])], 0);
    assert_eq!(buffers[0].ids()[pixel([1.25, 1.25, 0.5])], 1);
    // Filtering out the near quad uncovers the far one.
    buffers[1].clear();
    let (mesh, ids) = two_quads(true);
    render_ids_filtered(&mesh, &ids, &camera, &mut buffers[1], |p| p == 0);
    assert_eq!(buffers[1].ids()[pixel([0.25, 0.25, 0.5])], 0);
    assert_eq!(buffers[1].ids()[pixel([1.25, 1.25, 0.5])], NO_PATCH);
}

#[test]
fn random_fans_never_overdraw() {
    let mut rng = Rng::new(99);
    for _ in 0..50 {
        let (cx, cy) = (
            20.0 + 5.0 * rng.signed() as f64,
            20.0 + 5.0 * rng.signed() as f64,
        );
        let centre = vertex(cx, cy);
        // At least 5 spokes, so no gap between neighbouring spokes reaches half a turn.
        let k = 5 + (rng.next_u64() % 20) as usize;
        let rim: Vec<ScreenVertex> = (0..k)
            .map(|i| {
                let a = (i as f64 + 0.4 * rng.signed() as f64) / k as f64 * std::f64::consts::TAU;
                let r = 5.0 + 14.0 * (rng.signed() as f64 + 1.0);
                vertex(cx + r * a.cos(), cy + r * a.sin())
            })
            .collect();
        let tris: Vec<_> = (0..k).map(|i| [centre, rim[i], rim[(i + 1) % k]]).collect();
        for span in ALL_PATHS {
            let counts = screen_counts(&tris, 40, span);
            assert!(counts.iter().all(|&c| c <= 1));
            // Pixels around the centre vertex are always inside the star.
            let (cx, cy) = ((centre.x >> 8) as usize, (centre.y >> 8) as usize);
            assert_eq!(counts[cy * 40 + cx], 1);
        }
    }
}

#[test]
fn unclipped_projection_is_used_only_where_it_equals_the_full_one() {
    let camera = Camera::look_at([0.0, 0.0, 5.0], [0.0, 0.0, 0.0], 60.0, 64);
    let planes = view_planes(&camera);
    let mut rng = Rng::new(7);
    // A ball well inside the view: every point projects the same either way.
    assert!(sphere_needs_no_clip(&camera, [0.3, -0.2, 0.5], 1.0));
    for _ in 0..1000 {
        let p = [
            rng.signed() * 0.5 + 0.3,
            rng.signed() * 0.5 - 0.2,
            rng.signed() * 0.5 + 0.5,
        ];
        let (full, fast) = (project(&camera, &planes, p), project_unclipped(&camera, p));
        assert_eq!(full.outcode & NEEDS_CLIP, 0);
        assert_eq!((full.screen, full.outcode), (fast.screen, fast.outcode));
    }
    // Balls reaching the near plane, behind the eye, or far beyond the guard band are refused.
    assert!(!sphere_needs_no_clip(&camera, [0.0, 0.0, 4.0], 1.0));
    assert!(!sphere_needs_no_clip(&camera, [0.0, 0.0, 9.0], 1.0));
    assert!(!sphere_needs_no_clip(&camera, [1e6, 0.0, 0.0], 1.0));
    assert!(!sphere_needs_no_clip(&camera, [0.0, 0.0, 0.0], f32::NAN));
}

#[test]
fn batched_projection_equals_the_single_one_bit_for_bit() {
    let mut rng = Rng::new(11);
    // Eight lanes where the CPU has AVX2, and four lanes always.
    for mut batch in [ScreenBatch::default(), ScreenBatch::default().four_lanes()] {
        for (eye, resolution) in [([0.0, 0.0, 5.0], 64), ([3.0, -2.0, 4.0], 512)] {
            let camera = Camera::look_at(eye, [0.0, 0.0, 0.0], 45.0, resolution);
            for len in 0..=21 {
                let mut points: Vec<[f32; 3]> = (0..len)
                    .map(|_| [rng.signed(), rng.signed(), rng.signed()])
                    .collect();
                // The image centre: a half-pixel tie of the rounding.
                points.push([0.0, 0.0, 0.0]);
                batch.project(&camera, &points);
                for (i, &p) in points.iter().enumerate() {
                    let i = i as u16;
                    let single = project_unclipped(&camera, p).screen;
                    let [v, ..] = batch.triangle([i; 3]);
                    assert_eq!(
                        (v.x, v.y, v.q.to_bits()),
                        (single.x, single.y, single.q.to_bits())
                    );
                    assert_eq!(
                        batch.holds_no_centre([i; 3]),
                        codes_hold_no_centre([centre_code(single.x, single.y); 3])
                    );
                }
            }
        }
    }
}

#[test]
fn only_boxes_between_pixel_centres_cover_no_centre() {
    // Pixel centres at 128 and 384 sub-pixel units.
    let tri = |x: [i32; 3], y: [i32; 3]| {
        [0, 1, 2].map(|k| ScreenVertex {
            x: x[k],
            y: y[k],
            q: 1.0,
        })
    };
    assert!(covers_no_centre(tri([130, 380, 200], [130, 140, 380])));
    assert!(!covers_no_centre(tri([128, 380, 200], [130, 140, 384])));
    assert!(covers_no_centre(tri([385, 600, 500], [0, 1000, 500])));
}

fn screen_vertex() -> impl Strategy<Value = ScreenVertex> {
    let coordinate = prop_oneof![-4_000i32..16_000, -(1i32 << 28)..(1i32 << 28),];
    (coordinate.clone(), coordinate, 0.01f32..10.0).prop_map(|(x, y, q)| ScreenVertex { x, y, q })
}

/// Triangles of at most a few pixels, near or across the image border.
fn small_triangle() -> impl Strategy<Value = [ScreenVertex; 3]> {
    (
        -300i32..12_600,
        -300i32..12_600,
        proptest::array::uniform3((-700i32..700, -700i32..700, 0.01f32..10.0)),
    )
        .prop_map(|(x, y, offsets)| {
            offsets.map(|(dx, dy, q)| ScreenVertex {
                x: x + dx,
                y: y + dy,
                q,
            })
        })
}

proptest! {
    #[test]
    fn a_triangle_without_a_centre_in_its_box_draws_nothing(
        tri in prop_oneof![
            [screen_vertex(), screen_vertex(), screen_vertex()],
            small_triangle(),
        ],
        resolution in 1u32..48,
    ) {
        let mut covered_pixels = 0;
        scan_triangle(tri, resolution, DEFAULT_PATHS, |_, _, covered| {
            covered_pixels += u32::from(covered)
        });
        if covers_no_centre(tri) {
            prop_assert_eq!(covered_pixels, 0);
        }
    }

    #[test]
    fn centre_codes_tell_what_the_box_test_tells(
        tri in prop_oneof![
            [screen_vertex(), screen_vertex(), screen_vertex()],
            small_triangle(),
            // Corners on pixel centres and on the lines between them.
            proptest::array::uniform3((-4i32..8, -4i32..8, 0u8..4)).prop_map(|c| {
                c.map(|(x, y, k)| {
                    let on = |v: i32, centre: bool| v * 256 + if centre { 128 } else { 0 };
                    ScreenVertex { x: on(x, k & 1 == 1), y: on(y, k & 2 == 2), q: 1.0 }
                })
            }),
        ],
    ) {
        let codes = tri.map(|v| centre_code(v.x, v.y));
        prop_assert_eq!(codes_hold_no_centre(codes), covers_no_centre(tri));
    }
}

proptest! {
    #[test]
    fn every_pixel_path_gives_the_same_fragments(
        tri in prop_oneof![
            [screen_vertex(), screen_vertex(), screen_vertex()],
            small_triangle(),
        ],
        resolution in 1u32..48,
    ) {
        let fragments = |paths| {
            let mut out = Vec::new();
            scan_triangle(tri, resolution, paths, |i, q, covered| {
                if covered {
                    out.push((i, q.to_bits()))
                }
            });
            out
        };
        let walked = fragments(NEVER_SPANS);
        prop_assert_eq!(&walked, &fragments(ALWAYS_SPANS));
        prop_assert_eq!(&walked, &fragments(DEFAULT_PATHS));
    }

    #[test]
    fn random_triangles_draw_only_kept_ids(
        corners in proptest::collection::vec(
            proptest::array::uniform3(-2.0f32..2.0), 3..30),
        eye in proptest::array::uniform3(-3.0f32..3.0),
        target in proptest::array::uniform3(-1.0f32..1.0),
        fov in 5.0f32..170.0,
        resolution in 1u32..48,
    ) {
        let distance: f32 = (0..3).map(|i| (eye[i] - target[i]).powi(2)).sum::<f32>().sqrt();
        prop_assume!(distance > 0.01);
        let count = corners.len() / 3;
        let triangles = (0..count as u32).map(|t| [3 * t, 3 * t + 1, 3 * t + 2]).collect();
        let mesh = Mesh::from_memory("random", corners, triangles).unwrap();
        let patch_of: Vec<PatchId> = (0..count as u32).collect();
        let camera = Camera::look_at(eye, target, fov, resolution);
        let mut buffer = IdBuffer::new(resolution);
        render_ids_filtered(&mesh, &patch_of, &camera, &mut buffer, |p| p % 2 == 0);
        for &id in buffer.ids() {
            prop_assert!(id == NO_PATCH || (id % 2 == 0 && (id as usize) < count), "id {}", id);
        }
        prop_assert!(coverage_counts(&mesh, &camera).len() == (resolution * resolution) as usize);
    }
}
