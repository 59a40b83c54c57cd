//! End-to-end tests through the `patchvis` binary on the bundled bunny.
//!
//! The visibility check renders an ID buffer independently of the library — ray casting with
//! Möller–Trumbore against the reordered mesh written by `--mesh-out` — and asserts that
//! every patch it shows from a sampling position is in `patchvis query`'s answer there.

mod common;

use common::{BUNNY, Bake, Baked, bake, json, patchvis, rows, stderr};
use std::path::Path;

const RESOLUTION: u32 = 128;

/// The bunny in 200 patches, level 2, [`RESOLUTION`] px on `threads` threads, with
/// `--mesh-out` and `--stats`.
fn bake_small(threads: &str) -> Baked {
    let resolution = RESOLUTION.to_string();
    Bake::new(&[
        "--patches",
        "200",
        "--level",
        "2",
        "--resolution",
        &resolution,
    ])
    .env("RAYON_NUM_THREADS", threads)
    .mesh_out()
    .stats()
    .run()
}

/// The reordered mesh: positions, triangles and each triangle's patch.
struct PatchMesh {
    positions: Vec<[f32; 3]>,
    triangles: Vec<[u32; 3]>,
    patch: Vec<u32>,
}

/// Reads the `--mesh-out` PLY by its documented layout, without the library.
fn read_patch_mesh(path: &Path) -> PatchMesh {
    let bytes = std::fs::read(path).unwrap();
    let end = bytes
        .windows(11)
        .position(|w| w == b"end_header\n")
        .expect("end_header")
        + 11;
    let header = std::str::from_utf8(&bytes[..end]).unwrap();
    let count = |element: &str| -> usize {
        let line = header
            .lines()
            .find(|l| l.starts_with(&format!("element {element} ")))
            .unwrap();
        line.split_whitespace().nth(2).unwrap().parse().unwrap()
    };
    let (nv, nf) = (count("vertex"), count("face"));
    for expected in [
        "format binary_little_endian 1.0",
        "property float x",
        "property list uchar uint vertex_indices",
        "property uint patch",
        "property uchar red",
        "property uint orig_index",
    ] {
        assert!(
            header.contains(expected),
            "header lacks '{expected}':\n{header}"
        );
    }
    let f32_at = |o: usize| f32::from_le_bytes(bytes[o..o + 4].try_into().unwrap());
    let u32_at = |o: usize| u32::from_le_bytes(bytes[o..o + 4].try_into().unwrap());
    let positions = (0..nv)
        .map(|i| {
            [
                f32_at(end + 12 * i),
                f32_at(end + 12 * i + 4),
                f32_at(end + 12 * i + 8),
            ]
        })
        .collect();
    let faces = end + 12 * nv;
    let (mut triangles, mut patch) = (Vec::new(), Vec::new());
    for i in 0..nf {
        let o = faces + 24 * i;
        assert_eq!(bytes[o], 3);
        triangles.push([u32_at(o + 1), u32_at(o + 5), u32_at(o + 9)]);
        patch.push(u32_at(o + 13));
    }
    assert_eq!(faces + 24 * nf, bytes.len());
    PatchMesh {
        positions,
        triangles,
        patch,
    }
}

type V3 = [f64; 3];
fn sub(a: V3, b: V3) -> V3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn dot(a: V3, b: V3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn cross(a: V3, b: V3) -> V3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
fn norm(a: V3) -> V3 {
    let l = dot(a, a).sqrt();
    [a[0] / l, a[1] / l, a[2] / l]
}

/// Distance in pixels within which a pixel centre counts as on a triangle edge. Which of the
/// triangles sharing an edge owns such a pixel is up to the fill rule and to rounding (the
/// rasterizer snaps vertices to 1/256 pixel, moving an edge by up to ~1/360 pixel), so the
/// check ignores the few pixels whose nearest surface is that close to an edge.
const EDGE_MARGIN_PX: f64 = 1.0 / 128.0;

/// Patches seen from `eye` looking at `target` with their pixel counts (the spec's camera: up
/// +Y unless looking along Y, then +Z; row 0 at the top). Brute force in f64: every pixel centre
/// is tested against every projected triangle around it, the depth is the distance along the
/// pixel's ray to the triangle's plane, and the nearest wins. Pixels where a triangle passing
/// within [`EDGE_MARGIN_PX`] of the centre could change the winning patch are left out.
fn ray_cast_patches(
    mesh: &PatchMesh,
    eye: V3,
    target: V3,
    fov_deg: f64,
    res: u32,
) -> Vec<(u32, usize)> {
    let f = norm(sub(target, eye));
    let up0 = if dot(f, [0.0, 1.0, 0.0]).abs() > 0.999 {
        [0.0, 0.0, 1.0]
    } else {
        [0.0, 1.0, 0.0]
    };
    let r = norm(cross(f, up0));
    let u = cross(r, f);
    let tan = (fov_deg.to_radians() * 0.5).tan();
    let n = res as usize;
    let half = f64::from(res) * 0.5;
    let p64 = |v: u32| mesh.positions[v as usize].map(f64::from);
    // Calls `hit(pixel, distance, margin, triangle)` for every pixel centre within
    // `EDGE_MARGIN_PX` of every triangle (margin: signed distance to the nearest edge).
    let each_hit = |hit: &mut dyn FnMut(usize, f64, f64, usize)| {
        for (t, tri) in mesh.triangles.iter().enumerate() {
            let world = tri.map(p64);
            // Screen position in pixels (all vertices are in front of sampling cameras).
            let screen = world.map(|p| {
                let d = sub(p, eye);
                let z = dot(d, f);
                [
                    (dot(d, r) / z / tan + 1.0) * half,
                    (1.0 - dot(d, u) / z / tan) * half,
                ]
            });
            let normal = cross(sub(world[1], world[0]), sub(world[2], world[0]));
            let area2 = (screen[1][0] - screen[0][0]) * (screen[2][1] - screen[0][1])
                - (screen[1][1] - screen[0][1]) * (screen[2][0] - screen[0][0]);
            if area2 == 0.0 {
                continue;
            }
            // Signed distance to each edge, positive inside for either winding.
            let edge_distance = |k: usize, px: f64, py: f64| {
                let (a, b) = (screen[k], screen[(k + 1) % 3]);
                let len = ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2)).sqrt();
                ((b[0] - a[0]) * (py - a[1]) - (b[1] - a[1]) * (px - a[0])) * area2.signum() / len
            };
            let xs = screen.map(|s| s[0]);
            let ys = screen.map(|s| s[1]);
            let lo = |v: [f64; 3]| {
                (v.iter().fold(f64::MAX, |m, &x| m.min(x)) - 1.0)
                    .floor()
                    .max(0.0) as usize
            };
            let hi = |v: [f64; 3]| {
                ((v.iter().fold(f64::MIN, |m, &x| m.max(x)) + 1.0)
                    .ceil()
                    .max(0.0) as usize)
                    .min(n)
            };
            for y in lo(ys)..hi(ys) {
                for x in lo(xs)..hi(xs) {
                    let (px, py) = (x as f64 + 0.5, y as f64 + 0.5);
                    let margin = (0..3)
                        .map(|k| edge_distance(k, px, py))
                        .fold(f64::MAX, f64::min);
                    if margin < -EDGE_MARGIN_PX {
                        continue;
                    }
                    let (sx, sy) = ((px / half - 1.0) * tan, (1.0 - py / half) * tan);
                    let dir = [
                        f[0] + r[0] * sx + u[0] * sy,
                        f[1] + r[1] * sx + u[1] * sy,
                        f[2] + r[2] * sx + u[2] * sy,
                    ];
                    let dist = dot(normal, sub(world[0], eye)) / dot(normal, dir);
                    if dist > 0.0 {
                        hit(y * n + x, dist, margin, t);
                    }
                }
            }
        }
    };
    // Pass 1: the nearest triangle that covers the pixel centre beyond doubt (inside by more
    // than the margin): some triangle at least as near is drawn there by any rasterizer.
    let mut depth = vec![f64::INFINITY; n * n];
    let mut ids = vec![u32::MAX; n * n];
    each_hit(&mut |i, dist, margin, t| {
        if margin >= EDGE_MARGIN_PX && dist < depth[i] {
            depth[i] = dist;
            ids[i] = mesh.patch[t];
        }
    });
    // Pass 2: a nearer triangle that touches the centre only within the margin may or may not
    // win the pixel (rounding decides), and a pixel covered only within margins has no certain
    // winner. Such pixels are ambiguous unless the possible winners share the certain one's
    // patch; they are few, and the check ignores them.
    let mut ambiguous = vec![false; n * n];
    each_hit(&mut |i, dist, margin, t| {
        if margin < EDGE_MARGIN_PX && dist < depth[i] && mesh.patch[t] != ids[i] {
            ambiguous[i] = true;
        }
    });
    let mut seen: Vec<u32> = ids
        .iter()
        .zip(&ambiguous)
        .filter(|&(&p, &a)| p != u32::MAX && !a)
        .map(|(&p, _)| p)
        .collect();
    // Sub-pixel triangles put about one pixel centre in ten within the margin of an edge.
    let skipped = ambiguous.iter().filter(|&&a| a).count();
    assert!(
        seen.len() > 4 * skipped,
        "{skipped} pixels are ambiguous, {} are not",
        seen.len()
    );
    seen.sort_unstable();
    let mut counted: Vec<(u32, usize)> = Vec::new();
    for p in seen {
        match counted.last_mut() {
            Some((q, n)) if *q == p => *n += 1,
            _ => counted.push((p, 1)),
        }
    }
    counted
}

#[test]
fn queries_from_the_axis_views_contain_every_patch_a_ray_caster_sees() {
    let baked = bake_small("2");
    let pvis = baked.pvis_arg();
    let info = json(&patchvis(&["info", pvis, "--json"]));
    assert_eq!(info["triangles"], 99_785);
    assert_eq!(info["patches"], 200);
    assert_eq!(info["views"], 66);
    assert_eq!(info["level"], 2);
    let camera = &info["camera"];
    assert_eq!(camera["resolution"], RESOLUTION);
    let center: V3 = std::array::from_fn(|k| camera["center"][k].as_f64().unwrap());
    let distance = camera["distance"].as_f64().unwrap();
    let fov = camera["fov_deg"].as_f64().unwrap();

    let mesh = read_patch_mesh(&baked.mesh_out());
    assert_eq!(mesh.triangles.len(), 99_785);
    // Reordered: each patch is one contiguous, ascending run.
    assert!(mesh.patch.windows(2).all(|w| w[0] <= w[1]));

    for axis in [
        [1.0, 0.0, 0.0],
        [-1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, -1.0, 0.0],
        [0.0, 0.0, 1.0],
        [0.0, 0.0, -1.0],
    ] {
        let eye: V3 = std::array::from_fn(|k| center[k] + axis[k] * distance);
        let from = format!("{},{},{}", eye[0], eye[1], eye[2]);
        let answer = json(&patchvis(&["query", pvis, "--from", &from, "--json"]));
        let answered: Vec<u32> = answer["patches"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_u64().unwrap() as u32)
            .collect();
        let seen = ray_cast_patches(&mesh, eye, center, fov, RESOLUTION);
        assert!(
            seen.len() > 20,
            "the ray caster sees only {} patches from {axis:?}",
            seen.len()
        );
        let missing: Vec<(u32, usize)> = seen
            .iter()
            .copied()
            .filter(|(p, _)| !answered.contains(p))
            .collect();
        assert!(
            missing.is_empty(),
            "from {axis:?}: (patch, pixels) {missing:?} are visible but not in the answer"
        );
        // Ranges cover exactly the answered patches' triangles.
        let ranged: u64 = answer["ranges"]
            .as_array()
            .unwrap()
            .iter()
            .map(|r| r[1].as_u64().unwrap())
            .sum();
        let counted = mesh.patch.iter().filter(|p| answered.contains(p)).count() as u64;
        assert_eq!(ranged, counted);
        assert_eq!(answer["inside_sphere"], false);
    }
    // From the centre the camera is inside the sampling sphere.
    let from = format!("{},{},{}", center[0], center[1], center[2]);
    let inside = json(&patchvis(&["query", pvis, "--from", &from, "--json"]));
    assert_eq!(inside["inside_sphere"], true);

    let stats = baked.stats();
    let names: Vec<&str> = stats["stages"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s["name"].as_str().unwrap())
        .collect();
    for stage in ["tiling", "sampling", "encoding"] {
        assert!(
            names.contains(&stage),
            "stats lack stage {stage}: {names:?}"
        );
    }
    assert_eq!(stats["triangles"], 99_785);
    assert!(stats["peak_heap_bytes"].as_u64().unwrap() > 0);
}

#[test]
fn bakes_are_byte_identical_for_any_thread_count() {
    let (a, b) = (bake_small("1"), bake_small("2"));
    assert!(
        a.bytes() == b.bytes(),
        ".pvis differs between 1 and 2 threads"
    );
    assert!(
        std::fs::read(a.mesh_out()).unwrap() == std::fs::read(b.mesh_out()).unwrap(),
        "--mesh-out differs between 1 and 2 threads"
    );
}

/// Runs a bake expected to fail and returns its one-line error; asserts no output was left.
fn failing_bake(dir: &Path, args: &[&str], code: i32) -> String {
    let out_path = dir.join("out.pvis");
    let mut all = vec!["bake"];
    all.extend_from_slice(args);
    all.extend_from_slice(&[
        "-o",
        out_path.to_str().unwrap(),
        "--level",
        "0",
        "--resolution",
        "16",
    ]);
    let out = patchvis(&all);
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(code), "args {args:?}: {err}");
    assert_eq!(
        err.trim_end().lines().count(),
        1,
        "expected one line, got:\n{err}"
    );
    assert!(!err.contains("panicked"), "{err}");
    assert!(!out_path.exists(), "output left behind for {args:?}");
    let leftovers: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert!(
        leftovers
            .iter()
            .all(|n| n.to_string_lossy().ends_with(".ply")),
        "stray files {leftovers:?}"
    );
    err
}

#[test]
fn bad_invocations_fail_with_one_line_and_no_output() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let missing = d.join("missing.ply");
    let err = failing_bake(d, &[missing.to_str().unwrap()], 1);
    assert!(err.contains("missing.ply"), "{err}");

    let err = failing_bake(d, &[d.to_str().unwrap()], 1);
    assert!(
        err.contains(d.file_name().unwrap().to_str().unwrap()),
        "{err}"
    );

    let err = failing_bake(d, &[BUNNY, "--patches", "0"], 2);
    assert!(err.contains("--patches"), "{err}");
    let err = failing_bake(d, &[BUNNY, "--level", "99"], 2);
    assert!(err.contains("--level"), "{err}");
    let err = failing_bake(d, &[BUNNY, "--resolution", "0"], 2);
    assert!(err.contains("--resolution"), "{err}");

    let empty = d.join("empty.ply");
    std::fs::write(&empty, b"").unwrap();
    let err = failing_bake(d, &[empty.to_str().unwrap()], 1);
    assert!(err.contains("empty.ply"), "{err}");

    let points = d.join("points.ply");
    std::fs::write(
        &points,
        b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0\n1 0 0\n0 1 0\n",
    )
    .unwrap();
    let err = failing_bake(d, &[points.to_str().unwrap()], 1);
    assert!(err.contains("points.ply") && err.contains("face"), "{err}");

    let out = patchvis(&["bake"]);
    assert_eq!(out.status.code(), Some(2));
    let out = patchvis(&["query", BUNNY, "--from", "1,2"]);
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
}

#[test]
fn info_and_query_refuse_files_that_are_not_pvis() {
    let out = patchvis(&["info", BUNNY]);
    assert_eq!(out.status.code(), Some(1));
    let err = stderr(&out);
    assert!(
        err.contains("bunny.ply") && err.trim_end().lines().count() == 1,
        "{err}"
    );
    let out = patchvis(&["query", BUNNY, "--from", "0,0,1"]);
    assert_eq!(out.status.code(), Some(1));
}

#[test]
fn covisibility_numbering_renames_patches_and_keeps_always_visible_ids_spatial() {
    let bake = |order: &str| -> Vec<u8> {
        bake(&[
            "--patches",
            "120",
            "--level",
            "2",
            "--resolution",
            "64",
            "--view-supersample",
            "0",
            "--always-visible",
            "7",
            "--patch-order",
            order,
            "-q",
        ])
        .bytes()
    };
    let spatial = bake("spatial");
    let covisible = bake("covisibility");
    assert_ne!(spatial, covisible);
    let (a, b) = (
        patchvis::runtime::Pvis::parse(&spatial).unwrap(),
        patchvis::runtime::Pvis::parse(&covisible).unwrap(),
    );
    // Each renumbered patch is one spatial patch (same record), and its column is that
    // patch's column.
    let record = |p: patchvis::runtime::PatchInfo| {
        (
            p.triangle_count,
            p.center.map(f32::to_bits),
            p.radius.to_bits(),
        )
    };
    let spatial_id = |q: u32| {
        (0..a.patch_count())
            .find(|&p| record(a.patch(p)) == record(b.patch(q)))
            .expect("every renumbered patch is a spatial patch")
    };
    let ((_, rows_a), (_, rows_b)) = (rows(&spatial), rows(&covisible));
    assert_eq!(rows_a.views(), rows_b.views());
    let views = 0..rows_a.views();
    let mut renamed = 0;
    for q in 0..b.patch_count() {
        let p = spatial_id(q);
        renamed += usize::from(p != q);
        for v in views.clone() {
            assert_eq!(
                rows_a.get(v, p),
                rows_b.get(v, q),
                "patch {q} (spatial {p})"
            );
        }
    }
    assert!(renamed > 0, "the tour kept every id");
    // `--always-visible 7` means spatial patch 7, in every view of both files.
    assert!(views.clone().all(|v| rows_a.get(v, 7)));
    let moved = (0..b.patch_count()).find(|&q| spatial_id(q) == 7).unwrap();
    assert!(views.clone().all(|v| rows_b.get(v, moved)));
}

#[test]
fn info_compare_sizes_the_matrix_with_in_process_zstd_and_xz() {
    let dir = tempfile::tempdir().unwrap();
    let pvis = dir.path().join("bunny.pvis");
    let out = patchvis(&[
        "bake",
        BUNNY,
        "-o",
        pvis.to_str().unwrap(),
        "--patches",
        "60",
        "--level",
        "1",
        "--resolution",
        "32",
        "-q",
    ]);
    assert!(out.status.success(), "bake failed: {}", stderr(&out));
    let out = patchvis(&["info", pvis.to_str().unwrap(), "--compare"]);
    assert!(
        out.status.success(),
        "info --compare failed: {}",
        stderr(&out)
    );
    let text = String::from_utf8(out.stdout).unwrap();
    // The byte count after a row's label, e.g. `  zstd -19 (raw rows)   1234 B ...`.
    let size = |label: &str| -> u64 {
        let line = text
            .lines()
            .find(|l| l.trim_start().starts_with(label))
            .unwrap_or_else(|| panic!("no `{label}` line in:\n{text}"));
        let rest = line.trim_start()[label.len()..].trim_start();
        let (number, unit) = rest.split_once(' ').unwrap_or((rest, ""));
        assert!(unit.starts_with('B'), "{line}");
        number
            .parse()
            .unwrap_or_else(|_| panic!("no size in `{line}`"))
    };
    let raw = size("raw rows");
    let zstd = size("zstd -19 (raw rows)");
    let xz = size("xz -9 (raw rows)");
    assert!(zstd > 0 && xz > 0 && raw > 0, "{text}");
    assert!(size("zstd -19 (rows)") > 0, "{text}");
    assert!(!text.contains("n/a"), "{text}");
}

#[test]
fn dilate_beyond_the_memory_budget_is_refused_before_sampling() {
    // The bunny's patch graph takes about 4.6 MiB while it is built: more than 1 MiB.
    let baked = Bake::new(&["--dilate", "--memory", "1MiB", "-q"]).attempt();
    let err = stderr(&baked.output);
    assert_eq!(baked.output.status.code(), Some(1), "{err}");
    assert!(
        err.contains("--dilate") && err.contains("--memory 1 MiB") && err.lines().count() == 1,
        "{err}"
    );
    assert!(!baked.pvis.exists(), "nothing is written");
    // Within the budget the same bake runs.
    Bake::new(&["--dilate", "--level", "1", "--resolution", "64", "-q"]).run();
}

/// The version-4 file a bake wrote before sampling shells existed, for the flags of
/// [`SHELL_FLAGS`] (`tests/data/pvis/README.md`).
const VERSION_4_FILE: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/tests/data/pvis/bunny-p200-l2-r64-v4.pvis"
);

/// The small bake of the shells' tests: 200 patches, level 2, 64 px.
const SHELL_FLAGS: [&str; 6] = ["--patches", "200", "--level", "2", "--resolution", "64"];

/// The far band (format version 6): a default bake also samples shells at 2 and 256 sampling
/// distances, which come first in the file; the sampling sphere's and the near shells' rows
/// are those of a bake without it, byte for byte.
#[test]
fn default_bakes_sample_the_far_band_before_the_near_shells() {
    let default = Bake::new(&SHELL_FLAGS).stats().run();
    let out = common::stdout(&default.output);
    assert!(
        out.contains(
            "far views: 2 shells of 66 views (level 2) at 2.00, 256.00 sampling distances"
        ) && out.contains(", 4 sampling shells ("),
        "{out}"
    );
    let near = Bake::new(&SHELL_FLAGS)
        .args(&["--far-shells", "none"])
        .run();
    let (bytes, near_bytes) = (default.bytes(), near.bytes());
    let (pvis, v5) = (
        patchvis::runtime::Pvis::parse(&bytes).unwrap(),
        patchvis::runtime::Pvis::parse(&near_bytes).unwrap(),
    );
    assert_eq!((pvis.version(), pvis.shell_count()), (6, 4));
    assert_eq!((v5.version(), v5.shell_count()), (5, 2));
    assert_eq!(pvis.sampling_shell(), 2);
    let d = pvis.sampling().distance;
    assert_eq!(pvis.shell(0).distance, (f64::from(d) * 256.0) as f32);
    assert_eq!(pvis.shell(1).distance, (f64::from(d) * 2.0) as f32);
    let words = pvis.row_words();
    let (mut a, mut b) = (vec![0u64; words], vec![0u64; words]);
    for (s, t) in [(2, 0), (3, 1), (4, 2)] {
        assert_eq!(pvis.shell(s).distance, v5.shell(t).distance);
        for v in 0..pvis.shell(s).views {
            pvis.shell_view_row(s, v, &mut a);
            v5.shell_view_row(t, v, &mut b);
            assert_eq!(a, b, "shell {s} view {v}");
        }
    }
    let shells = default.stats()["shells"].as_array().unwrap().clone();
    assert_eq!(shells.len(), 4);
    assert_eq!(shells[0]["views"], 66);
}

/// Near cameras (issue 22): a default bake samples two shells at `D·(1.1·R/D)^(s/2)`, each
/// with the stored level's views and supersampling, reported in `--stats` and the summary;
/// `--shells 0` writes the bytes bakes wrote before shells, and the bytes each shell adds
/// are the difference.
#[test]
fn default_bakes_sample_two_shells_and_shells_0_writes_the_version_4_bytes() {
    let default = Bake::new(&SHELL_FLAGS)
        .args(&["--far-shells", "none"])
        .stats()
        .run();
    let out = common::stdout(&default.output);
    assert!(
        out.contains("near views: 2 shells of 66 views (level 2) at 1.70, 1.10 bounding radii")
            && out.contains(", 2 sampling shells ("),
        "{out}"
    );
    let stats = default.stats();
    let bytes = default.bytes();
    let pvis = patchvis::runtime::Pvis::parse(&bytes).unwrap();
    assert_eq!((pvis.version(), pvis.shell_count()), (5, 2));
    let (d, r) = (
        f64::from(pvis.sampling().distance),
        f64::from(pvis.sampling().radius),
    );
    let shells = stats["shells"].as_array().expect("a list of shells");
    assert_eq!(shells.len(), 2, "{stats}");
    let mut outer = d as f32;
    for (s, shell) in shells.iter().enumerate() {
        let distance = shell["distance"].as_f64().unwrap() as f32;
        let expected = (d * (1.1 * r / d).powf((s + 1) as f64 / 2.0)) as f32;
        assert!(
            (distance - expected).abs() <= expected * f32::EPSILON,
            "shell {s} at {distance}, expected {expected}"
        );
        assert!(distance < outer && f64::from(distance) >= r, "{stats}");
        outer = distance;
        assert_eq!(shell["level"], 2);
        assert_eq!(shell["views"], 66);
        // The file carries it: format version 5, shell `s + 1` of its SHEL section.
        let stored = pvis.shell(s as u32 + 1);
        assert_eq!(
            (stored.distance, stored.level, stored.views),
            (distance, 2, 66)
        );
        // The stored level folded from one finer level, as the sampling sphere.
        assert_eq!(shell["sampled_views"], 258);
        assert!(shell["seconds"].as_f64().unwrap() > 0.0);
    }
    // The sampling sphere's own, as before shells.
    assert_eq!(stats["sampled_views"], 258);
    // That file predates the probe pass of the default bake and saturated rows (hence
    // `--sampled-rows`). Without the probe, the
    // sampling sphere's rows do not depend on the shells (the probe's cells span the
    // camera distances the sphere answers for, which the shells bound).
    let none = Bake::new(&SHELL_FLAGS)
        .args(&["--shells", "0", "--far-shells", "none", "--probe", "off"])
        .args(&["--sampled-rows"])
        .stats()
        .run();
    assert!(
        none.bytes() == std::fs::read(VERSION_4_FILE).unwrap(),
        "--shells 0 differs from the version-4 file of bakes before shells"
    );
    assert_eq!(none.stats()["shells"], serde_json::json!([]));
    let plain = Bake::new(&SHELL_FLAGS)
        .args(&["--far-shells", "none", "--probe", "off", "--sampled-rows"])
        .stats()
        .run();
    let plain_shells = plain.stats()["shells"].as_array().unwrap().clone();
    let added: u64 = plain_shells
        .iter()
        .map(|s| s["bytes"].as_u64().unwrap())
        .sum();
    assert_eq!(added, (plain.bytes().len() - none.bytes().len()) as u64);
}

/// `--shell-resolution` renders the shells' views coarser and leaves the sampling sphere's
/// rows as they are.
#[test]
fn the_shells_may_be_sampled_coarser() {
    let small = ["--patches", "100", "--level", "1", "--resolution", "64"];
    let full = bake(&small);
    let coarse = Bake::new(&small).args(&["--shell-resolution", "32"]).run();
    assert_ne!(coarse.bytes(), full.bytes());
    assert_eq!(rows(&coarse.bytes()), rows(&full.bytes()));
    // At --resolution, the same file.
    let same = Bake::new(&small).args(&["--shell-resolution", "64"]).run();
    assert_eq!(same.bytes(), full.bytes());
}

/// The shells' flags out of range: one line, exit code 2, no output.
#[test]
fn bad_shell_flags_are_usage_errors() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for (flags, needle) in [
        (&["--shells", "9"][..], "--shells 9: expected 0"),
        (&["--shell-min", "1"], "--shell-min 1: expected"),
        (&["--shell-min", "0.5"], "above 1 and below 2.613"),
        (&["--shell-min", "2.7"], "--shell-min 2.7"),
        (&["--shell-min", "NaN"], "--shell-min NaN"),
        (&["--fov", "120", "--shell-min", "1.2"], "below 1.155"),
        (&["--shell-level", "8"], "--shell-level 8"),
        (
            &["--shell-resolution", "8"],
            "--shell-resolution 8: expected 16 to",
        ),
        (
            &["--shell-resolution", "1024"],
            "expected 16 to --resolution (",
        ),
    ] {
        let mut args = vec![BUNNY];
        args.extend_from_slice(flags);
        let err = failing_bake(d, &args, 2);
        assert!(err.contains(needle), "{flags:?}: {err}");
    }
    // So close to the sampling sphere that 8 shells cannot be told apart in binary32: found
    // with the mesh, before the tiling.
    let out_path = d.join("out.pvis");
    let out = patchvis(&[
        "bake",
        BUNNY,
        "-o",
        out_path.to_str().unwrap(),
        "--shells",
        "8",
        "--far-shells",
        "none",
        "--shell-min",
        "2.6131255",
    ]);
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.starts_with("error: --shells 8 --shell-min 2.6131255: shell 1 would be at")
            && err.contains("not inside the sampling sphere")
            && err.contains("use fewer shells")
            && err.lines().count() == 1,
        "{err}"
    );
    assert!(!out_path.exists());
    let out = patchvis(&["bake", BUNNY, "-o", "x.pvis", "--shells", "-1"]);
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
}

/// `bake --help` (and `-h`) fits a screen: the everyday options, then a last line pointing to
/// `--help-all` and docs/bake.md. `--help-all` adds the research options under their own
/// heading, and docs/bake.md documents every one of them.
#[test]
fn bake_help_fits_a_screen_and_help_all_adds_the_research_options() {
    let help = patchvis(&["bake", "--help"]);
    assert_eq!(help.status.code(), Some(0), "{}", stderr(&help));
    let text = common::stdout(&help);
    let lines = text.lines().count();
    assert!(lines <= 80, "bake --help has {lines} lines:\n{text}");
    assert_eq!(common::stdout(&patchvis(&["bake", "-h"])), text);
    for everyday in [
        "--output",
        "--patches",
        "--level",
        "--resolution",
        "--conservative",
        "--mesh-out",
        "--memory",
        "--backend",
        "--stats",
        "--resume",
        "--shard",
        "--shells",
        "--far-shells",
        "--help-all",
    ] {
        assert!(
            text.contains(everyday),
            "bake --help lacks {everyday}:\n{text}"
        );
    }
    let last = text.trim_end().lines().last().unwrap();
    assert!(
        last.contains("--help-all") && last.contains("docs/bake.md"),
        "last line: {last}"
    );
    let research = [
        "--fold-corners",
        "--finer-views",
        "--fold-min-pixels",
        "--sampled-rows",
        "--probe",
        "--apertures",
        "--conservative-raster",
        "--view-supersample",
        "--shell-min",
        "--shell-level",
        "--shell-resolution",
        "--min-pixels",
        "--patch-order",
        "--encoding",
        "--dilate",
    ];
    for option in research {
        assert!(
            !text.contains(option),
            "bake --help shows {option}:\n{text}"
        );
    }

    let all = patchvis(&["bake", "--help-all"]);
    assert_eq!(all.status.code(), Some(0), "{}", stderr(&all));
    let all = common::stdout(&all);
    let heading = all.find("Research options:").expect("a research heading");
    let docs =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/docs/bake.md")).unwrap();
    let (_, research_part) = all.split_at(heading);
    for option in research {
        let listed = research_part
            .lines()
            .any(|line| line.trim_start().split(' ').next() == Some(option));
        assert!(listed, "{option} is not under the research heading:\n{all}");
    }
    // Every option --help-all lists is documented in docs/bake.md.
    for line in all.lines() {
        // Option lines are indented by 2 or 6 spaces, their help by 10.
        let words = line.trim_start();
        if line.len() - words.len() >= 10 || !words.starts_with('-') {
            continue;
        }
        let flag = words
            .split([' ', ','])
            .find(|w| w.starts_with("--"))
            .unwrap();
        let documented = [" ", "`"]
            .iter()
            .any(|end| docs.contains(&format!("{flag}{end}")));
        assert!(
            documented || flag.starts_with("--help"),
            "docs/bake.md lacks {flag}"
        );
    }
}

/// `gen` does not depend on the working directory: the kinds that start from a mesh need
/// `--source` and say so (exit 2, nothing written); the others, and those given a source, run
/// anywhere.
#[test]
fn gen_runs_outside_the_repository() {
    let dir = tempfile::tempdir().unwrap();
    let gen_in = |args: &[&str]| {
        std::process::Command::new(env!("CARGO_BIN_EXE_patchvis"))
            .arg("gen")
            .args(args)
            .current_dir(dir.path())
            .output()
            .unwrap()
    };
    for kind in ["subdivided-bunny", "bunny-grid"] {
        let out = gen_in(&["--kind", kind, "--triangles", "1000", "-o", "m.ply", "-q"]);
        assert_eq!(out.status.code(), Some(2), "{kind}: {}", stderr(&out));
        let err = stderr(&out);
        assert!(
            err.contains(&format!("--kind {kind} needs --source MESH.ply")),
            "{err}"
        );
        assert_eq!(err.trim_end().lines().count(), 1, "{err}");
        assert!(!dir.path().join("m.ply").exists());
    }
    let out = gen_in(&[
        "--kind",
        "truss",
        "--triangles",
        "2000",
        "-o",
        "t.ply",
        "-q",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let out = gen_in(&[
        "--kind",
        "bunny-grid",
        "--triangles",
        "1000",
        "--source",
        BUNNY,
        "-o",
        "g.ply",
        "-q",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(dir.path().join("t.ply").exists() && dir.path().join("g.ply").exists());
}
