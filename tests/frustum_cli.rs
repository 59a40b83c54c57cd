//! Frustum culling through the binary (issue 22, part 3): `patchvis query` with a look-at camera
//! or a view-projection matrix returns the answer less exactly the patches whose bounding
//! spheres lie outside the camera's frustum, judged here independently in binary64; and
//! `patchvis eval --look-jitter` reports the culling with the frustum while the frustum drops
//! no patch the answer draws.
//! The expanded reader's shortcuts are checked against the per-patch rule on many seeded frusta
//! whose planes cut the bunny.

mod common;

use common::{BUNNY, SMALL_QUIET, bake, json, number, patchvis, stderr};
use patchvis::runtime::Pvis;

/// Column-major `a · b`.
fn multiply(a: &[f64; 16], b: &[f64; 16]) -> [f64; 16] {
    std::array::from_fn(|i| (0..4).map(|k| a[4 * k + i % 4] * b[4 * (i / 4) + k]).sum())
}

/// A right-handed look-at and perspective (vertical fov, aspect 1, near 1, far 1000) with a
/// `0 ≤ z ≤ w` depth range, as Vulkan and wgpu use; world up +Y.
fn zero_to_one_view_projection(eye: [f64; 3], target: [f64; 3], fov_deg: f64) -> [f32; 16] {
    let f = unit(sub(target, eye));
    let s = unit(cross(f, [0.0, 1.0, 0.0]));
    let u = cross(s, f);
    let view = [
        s[0],
        u[0],
        -f[0],
        0.0,
        s[1],
        u[1],
        -f[1],
        0.0,
        s[2],
        u[2],
        -f[2],
        0.0,
        -dot(s, eye),
        -dot(u, eye),
        dot(f, eye),
        1.0,
    ];
    let g = 1.0 / (fov_deg.to_radians() / 2.0).tan();
    let (near, far) = (1.0, 1000.0);
    let projection = [
        g,
        0.0,
        0.0,
        0.0,
        0.0,
        g,
        0.0,
        0.0,
        0.0,
        0.0,
        far / (near - far),
        -1.0,
        0.0,
        0.0,
        far * near / (near - far),
        0.0,
    ];
    multiply(&projection, &view).map(|v| v as f32)
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
fn unit(a: [f64; 3]) -> [f64; 3] {
    let l = dot(a, a).sqrt();
    a.map(|c| c / l)
}

/// The largest signed distance-over-radius by which a sphere lies outside one of the frustum's
/// planes (> 0: wholly outside that plane), from the matrix in binary64.
fn outside_by(m: &[f32; 16], zero_to_one: bool, center: [f32; 3], radius: f32) -> f64 {
    let row = |i: usize| [m[i], m[4 + i], m[8 + i], m[12 + i]].map(f64::from);
    let (r0, r1, r2, r3) = (row(0), row(1), row(2), row(3));
    let plus = |a: [f64; 4], b: [f64; 4]| std::array::from_fn::<f64, 4, _>(|k| a[k] + b[k]);
    let minus = |a: [f64; 4], b: [f64; 4]| std::array::from_fn::<f64, 4, _>(|k| a[k] - b[k]);
    let near = if zero_to_one { r2 } else { plus(r3, r2) };
    let c = center.map(f64::from);
    [
        plus(r3, r0),
        minus(r3, r0),
        plus(r3, r1),
        minus(r3, r1),
        near,
        minus(r3, r2),
    ]
    .iter()
    .map(|p| {
        let n = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
        (-(p[0] * c[0] + p[1] * c[1] + p[2] * c[2] + p[3]) / n - f64::from(radius))
            / f64::from(radius).max(1e-9)
    })
    .fold(f64::NEG_INFINITY, f64::max)
}

fn patches(report: &serde_json::Value) -> Vec<u32> {
    report["patches"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| p.as_u64().unwrap() as u32)
        .collect()
}

#[test]
fn query_drops_exactly_the_patches_outside_the_frustum() {
    let baked = bake(&SMALL_QUIET);
    let pvis_path = baked.pvis_arg();
    let bytes = baked.bytes();
    let pvis = Pvis::parse(&bytes).unwrap();
    let s = pvis.sampling();
    let c = s.center.map(f64::from);
    let eye = [c[0], c[1], c[2] + 1.5 * f64::from(s.distance)];
    let eye_arg = format!("{},{},{}", eye[0] as f32, eye[1] as f32, eye[2] as f32);
    let plain = json(&patchvis(&[
        "query", pvis_path, "--eye", &eye_arg, "--json",
    ]));
    assert!(plain.get("outside_frustum").is_none());
    let plain = patches(&plain);

    // Aimed beside the model so that the frustum's left side cuts through it.
    let r = f64::from(s.radius);
    let target = [c[0] + 1.2 * r, c[1], c[2]];
    let m = zero_to_one_view_projection(eye, target, 30.0);
    let matrix = m.map(|v| v.to_string()).join(",");
    let out = patchvis(&[
        "query",
        pvis_path,
        "--eye",
        &eye_arg,
        "--view-proj",
        &matrix,
        "--depth",
        "zero-to-one",
        "--json",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let report = json(&out);
    let culled = patches(&report);
    let (mut kept, mut dropped) = (0, 0);
    for &p in &plain {
        let info = pvis.patch(p);
        let by = outside_by(&m, true, info.center, info.radius);
        let in_answer = culled.contains(&p);
        // Spheres reaching into the frustum are kept; those clearly outside are dropped.
        if by < -1e-4 {
            assert!(
                in_answer,
                "patch {p} reaches into the frustum ({by}) but was dropped"
            );
            kept += 1;
        } else if by > 1e-4 {
            assert!(
                !in_answer,
                "patch {p} lies outside the frustum ({by}) but was kept"
            );
            dropped += 1;
        }
    }
    assert!(culled.iter().all(|p| plain.contains(p)));
    assert!(kept > 10 && dropped > 10, "kept {kept}, dropped {dropped}");
    assert_eq!(
        number(&report, "outside_frustum") as usize,
        plain.len() - culled.len()
    );
    let triangles: u64 = culled
        .iter()
        .map(|&p| u64::from(pvis.patch(p).triangle_count))
        .sum();
    assert_eq!(report["triangles"].as_u64().unwrap(), triangles);

    // The same camera with the OpenGL depth range through --look-at: the near and far planes
    // differ, the sides the same, so the answer is too.
    let target_arg = format!(
        "{},{},{}",
        target[0] as f32, target[1] as f32, target[2] as f32
    );
    let look = json(&patchvis(&[
        "query",
        pvis_path,
        "--eye",
        &eye_arg,
        "--look-at",
        &target_arg,
        "--fov",
        "30",
        "--json",
    ]));
    assert_eq!(patches(&look), culled);
    // Looking at the centre with the default 45° the whole model is in view: nothing dropped.
    let centre = format!("{},{},{}", s.center[0], s.center[1], s.center[2]);
    let all = patchvis(&["query", pvis_path, "--eye", &eye_arg, "--look-at", &centre]);
    let text = String::from_utf8_lossy(&all.stdout).to_string();
    assert!(text.contains("0 outside the frustum"), "{text}");
    // Looking away from the model: nothing is left.
    let away = format!(
        "{},{},{}",
        eye[0] as f32,
        eye[1] as f32,
        (eye[2] + 10.0) as f32
    );
    let none = json(&patchvis(&[
        "query",
        pvis_path,
        "--eye",
        &eye_arg,
        "--look-at",
        &away,
        "--json",
    ]));
    assert!(patches(&none).is_empty());
    assert_eq!(number(&none, "outside_frustum") as usize, plain.len());
}

#[test]
fn frustum_flags_out_of_place_are_usage_errors() {
    let baked = bake(&SMALL_QUIET);
    let pvis = baked.pvis_arg();
    for args in [
        &["--eye", "0,0,100", "--fov", "30"][..],
        &["--eye", "0,0,100", "--depth", "zero-to-one"],
        &["--eye", "0,0,100", "--look-at", "0,0,100"],
        &["--eye", "0,0,100", "--look-at", "0,0,0", "--fov", "180"],
        &[
            "--eye",
            "0,0,100",
            "--look-at",
            "0,0,0",
            "--near",
            "5",
            "--far",
            "4",
        ],
        &["--eye", "0,0,100", "--view-proj", "1,0,0"],
        &[
            "--eye",
            "0,0,100",
            "--look-at",
            "0,0,0",
            "--view-proj",
            &["1"; 16].join(","),
        ],
    ] {
        let mut all = vec!["query", pvis];
        all.extend_from_slice(args);
        let out = patchvis(&all);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {}", stderr(&out));
        assert_eq!(
            stderr(&out)
                .trim_end()
                .lines()
                .filter(|l| l.starts_with("error"))
                .count(),
            1
        );
        assert!(out.stdout.is_empty());
    }
}

#[test]
fn eval_with_look_jitter_culls_more_with_the_frustum_and_loses_no_pixel() {
    let baked = bake(&SMALL_QUIET);
    let pvis = baked.pvis_arg();
    let run = |jitter: &str| {
        json(&patchvis(&[
            "eval",
            BUNNY,
            pvis,
            "--views",
            "12",
            "--seed",
            "5",
            "--look-jitter",
            jitter,
            "--frame-backend",
            "cpu",
            "--json",
        ]))
    };
    let straight = run("0");
    let jittered = run("25");
    assert_eq!(straight["look_jitter_deg"], 0.0);
    // Looking at the centre from the sampling distance the model fills the view: the frustum
    // culls nothing more.
    assert_eq!(
        number(&straight, "frustum_culling_rate_mean"),
        number(&straight, "culling_rate_mean")
    );
    let mut more = 0;
    for v in jittered["per_view"].as_array().unwrap() {
        assert_eq!(number(v, "frustum_lost_patches"), 0.0, "{v}");
        assert!(number(v, "frustum_culling_rate") >= number(v, "culling_rate"));
        // The frustum never culls past the ideal, which counts only what the render shows.
        assert!(
            number(v, "frustum_culling_rate") <= number(v, "ideal_culling_rate") + 1e-12
                || number(v, "missed_patches") > 0.0
        );
        more += usize::from(number(v, "frustum_culling_rate") > number(v, "culling_rate"));
    }
    assert!(
        more >= 6,
        "the frustum culled more in only {more} of 12 views"
    );
    assert_eq!(jittered["views_losing_a_patch_to_the_frustum"], 0);
    assert!(
        number(&jittered, "frustum_culling_rate_mean")
            > number(&jittered, "culling_rate_mean") + 0.05
    );
    let out = patchvis(&["eval", BUNNY, pvis, "--look-jitter", "-1"]);
    assert_eq!(out.status.code(), Some(2));
}

/// The six planes `[a, b, c, d]` (inside `≥ 0`) of a camera at `eye` looking at `target`
/// with a vertical and horizontal half-angle of `half_deg` and near and far distances.
fn planes(eye: [f64; 3], target: [f64; 3], half_deg: f64, near: f64, far: f64) -> [[f32; 4]; 6] {
    let f = unit(sub(target, eye));
    let s = unit(cross(f, [0.0, 1.0, 0.0]));
    let u = cross(s, f);
    let (sin, cos) = half_deg.to_radians().sin_cos();
    // A side plane's inward normal leans from the side axis towards the view direction.
    let side = |axis: [f64; 3], sign: f64| {
        let n: [f64; 3] = std::array::from_fn(|i| sign * cos * axis[i] + sin * f[i]);
        [n[0], n[1], n[2], -dot(n, eye)]
    };
    let along = |sign: f64, at: f64| {
        let n = f.map(|v| sign * v);
        [n[0], n[1], n[2], -dot(n, eye) - sign * at]
    };
    [
        side(s, 1.0),
        side(s, -1.0),
        side(u, 1.0),
        side(u, -1.0),
        along(1.0, near),
        along(-1.0, far),
    ]
    .map(|p| p.map(|v| v as f32))
}

/// Many seeded frusta whose sides, near and far planes cut the 1000-patch bunny: the
/// expanded query (its spatial hierarchy of patch bounds) returns exactly the stateless
/// query's bits, which are the plain answer less the patches `Frustum::keeps_patch` drops.
#[test]
fn expanded_frustum_query_matches_stateless_on_frusta_cutting_the_bunny() {
    use patchvis::runtime::Frustum;
    let baked = bake(&[
        "--patches",
        "1000",
        "--level",
        "2",
        "--resolution",
        "128",
        "-q",
    ]);
    let bytes = baked.bytes();
    let pvis = Pvis::parse(&bytes).unwrap();
    let s = pvis.sampling();
    let (c, r, dist) = (
        s.center.map(f64::from),
        f64::from(s.radius),
        f64::from(s.distance),
    );
    let mut scratch = vec![0u64; pvis.scratch_words()];
    let mut table = vec![0u64; pvis.expanded_bound()];
    let mut expanded = pvis.expand(&mut table);
    let mut state = 0x9E37_79B9_7F4A_7C15u64;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let (mut cut, mut settled_in) = (0, 0);
    for i in 0..3000 {
        let dir = unit([next() - 0.5, next() - 0.5, next() - 0.5]);
        // Outside the sampling sphere mostly, sometimes inside the model's bounding sphere.
        let at = if i % 10 == 0 {
            0.5 * r
        } else {
            dist * (0.6 + 2.0 * next())
        };
        let eye: [f64; 3] = std::array::from_fn(|k| c[k] + dir[k] * at);
        let target: [f64; 3] = std::array::from_fn(|k| c[k] + (next() - 0.5) * 3.0 * r);
        let to_centre = dot(sub(c, eye), sub(c, eye)).sqrt();
        let near = if i % 3 == 0 {
            (to_centre - r * next()).max(1e-3)
        } else {
            1e-3
        };
        let far = if i % 5 == 0 {
            to_centre + r * (next() - 0.5)
        } else {
            1e3 * dist
        };
        let frustum = Frustum::from_planes(planes(eye, target, 5.0 + 40.0 * next(), near, far));
        let eye = eye.map(|v| v as f32);
        let mut reference = pvis.query(eye, &mut scratch).bits().to_vec();
        let before: u32 = reference.iter().map(|w| w.count_ones()).sum();
        for p in 0..pvis.patch_count() {
            if !frustum.keeps_patch(&pvis.patch(p)) {
                reference[p as usize / 64] &= !(1 << (p % 64));
            }
        }
        let after: u32 = reference.iter().map(|w| w.count_ones()).sum();
        cut += usize::from(after > 0 && after < before);
        settled_in += usize::from(after == before);
        let stateless = pvis
            .query_in_frustum(eye, &frustum, &mut scratch)
            .bits()
            .to_vec();
        assert_eq!(stateless, reference, "frustum {i}");
        let bits = expanded.query_in_frustum(eye, &frustum).bits().to_vec();
        assert_eq!(bits, reference, "frustum {i}");
    }
    assert!(
        cut > 1000 && settled_in > 100,
        "{cut} cut, {settled_in} kept whole"
    );
}
