//! Sampling shells (spec § SHEL, § Query) across the query modes: files with 1–3 shells of
//! mixed levels in each encoding, written by `format::encode_with` from known rows, answered by
//! the stateless, streaming and expanded queries (with and without a frustum) and compared with
//! a reference that applies the band rule literally to the writer's own rows.

extern crate std;

use std::vec;
use std::vec::Vec;

use super::*;
use crate::format::{BakeContents, ShellRows, VisibilityEncoding, encode_with};
use crate::sphere::{direction, locate, view_count};
use crate::test_kit::rng::Rng;
use crate::tiling::Patch;
use crate::visibility::{SamplingParams, VisibilityMatrix};

/// What a test file holds: its bytes, and the rows of shell 0 (the sampling sphere) and of
/// each shell with its distance, as written.
struct Synthetic {
    bytes: Vec<u8>,
    distances: Vec<f32>,
    rows: Vec<VisibilityMatrix>,
}

/// Rows for `level`'s views over `patches` patches: each view sees the patches whose axis
/// faces it, more of them the nearer the shell (`near` in `[0, 1)`), plus seeded noise.
fn rows(level: u32, axes: &[[f32; 3]], near: f32, rng: &mut Rng) -> VisibilityMatrix {
    let views = view_count(level);
    let mut m = VisibilityMatrix::new(views, axes.len() as u32);
    for v in 0..views {
        let d = direction(v);
        for (p, a) in axes.iter().enumerate() {
            let facing = a[0] * d[0] + a[1] * d[1] + a[2] * d[2] > -0.2 - near;
            if facing != rng.next_u64().is_multiple_of(17) {
                m.set(v, p as u32);
            }
        }
    }
    m
}

/// A file with shells at `levels[1..]` (shell 0 at `levels[0]`) and `patches` patches, centred
/// at `center`, in `encoding`.
fn synthetic(
    levels: &[u32],
    patches: u32,
    center: [f32; 3],
    encoding: VisibilityEncoding,
    seed: u64,
) -> Synthetic {
    let mut rng = Rng::new(seed);
    let params = SamplingParams {
        level: levels[0],
        resolution: 64,
        fov_deg: 60.0,
        center,
        radius: 1.5,
    };
    let outer = params.distance();
    let axes: Vec<[f32; 3]> = (0..patches)
        .map(|_| {
            let v = [rng.signed(), rng.signed(), rng.signed()];
            let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt().max(1e-3);
            v.map(|x| x / n)
        })
        .collect();
    let list: Vec<Patch> = axes
        .iter()
        .enumerate()
        .map(|(i, &axis)| Patch {
            first: i as u32 * 2,
            count: 2,
            area: 1.0,
            center: [0, 1, 2].map(|k| center[k] + 0.5 * axis[k]),
            radius: 0.25,
            cone_axis: axis,
            cone_cos: 0.5,
        })
        .collect();
    let k = levels.len() - 1;
    let mut distances = vec![outer];
    let mut matrices = vec![rows(levels[0], &axes, 0.0, &mut rng)];
    for (s, &level) in levels.iter().enumerate().skip(1) {
        // Evenly from the sampling distance to just above the radius.
        let t = s as f32 / k as f32;
        distances.push(outer + (1.55 - outer) * t);
        matrices.push(rows(level, &axes, 0.3 * t, &mut rng));
    }
    let shells: Vec<ShellRows> = (1..=k)
        .map(|s| ShellRows {
            distance: distances[s],
            visibility: &matrices[s],
        })
        .collect();
    let contents = BakeContents {
        sampling: &params,
        triangle_count: 2 * u64::from(patches),
        patches: &list,
        visibility: &matrices[0],
        shells: &shells,
    };
    let bytes = encode_with(&contents, encoding);
    Synthetic {
        bytes,
        distances,
        rows: matrices,
    }
}

/// § Query applied literally: the band from binary64 squares, each answering shell's leaf by
/// `sphere::locate` at its level, and the OR of the written rows of its corners.
fn reference(f: &Synthetic, levels: &[u32], center: [f32; 3], eye: [f32; 3]) -> (u32, Vec<u64>) {
    let words = f.rows[0].words_per_row();
    let d = [0, 1, 2].map(|i| eye[i] - center[i]);
    let k = levels.len() as u32 - 1;
    if !d.iter().all(|x| x.is_finite()) {
        let mut all = vec![0u64; words];
        for p in 0..f.rows[0].patches() {
            all[p as usize / 64] |= 1 << (p % 64);
        }
        return (k + 1, all);
    }
    let q = (f64::from(d[0]) * f64::from(d[0]) + f64::from(d[1]) * f64::from(d[1]))
        + f64::from(d[2]) * f64::from(d[2]);
    let band = f
        .distances
        .iter()
        .filter(|&&r| q < f64::from(r) * f64::from(r))
        .count() as u32;
    let shells = if band == 0 {
        vec![0]
    } else if band > k {
        vec![k]
    } else {
        vec![band - 1, band]
    };
    let mut out = vec![0u64; words];
    for s in shells {
        for v in locate(d, levels[s as usize]).views {
            for (o, r) in out.iter_mut().zip(f.rows[s as usize].row(v)) {
                *o |= r;
            }
        }
    }
    (band, out)
}

/// Eyes in every band: random directions at radii drawn inside each band, on each shell's
/// sphere along an axis (exactly on it when the centre is the origin), at the centre, and
/// non-finite.
fn eyes(f: &Synthetic, center: [f32; 3], rng: &mut Rng) -> Vec<[f32; 3]> {
    let mut radii: Vec<f32> = vec![2.0 * f.distances[0], 0.0, 1.0];
    for w in f.distances.windows(2) {
        radii.extend([w[0], 0.5 * (w[0] + w[1]), w[1]]);
    }
    radii.extend(f.distances.iter().copied());
    let mut out = vec![[f32::NAN, 0.0, 0.0], center];
    for (i, &r) in radii.iter().enumerate() {
        for _ in 0..40 {
            let v = [rng.signed(), rng.signed(), rng.signed()];
            let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt().max(1e-3);
            let jitter = 1.0 + 0.02 * rng.signed();
            out.push([0, 1, 2].map(|k| center[k] + v[k] / n * r * jitter));
        }
        let axis = i % 3;
        let mut e = center;
        e[axis] += r;
        out.push(e);
    }
    out
}

/// Every mode answers every eye like the reference, in files with 1–3 shells of mixed levels,
/// in each encoding, centred at the origin (eyes exactly on the shells) and off it.
#[test]
fn every_mode_answers_like_the_band_rule() {
    let cases: [(&[u32], VisibilityEncoding, [f32; 3]); 6] = [
        (&[2, 2], VisibilityEncoding::Tree, [0.0; 3]),
        (&[2, 1, 3], VisibilityEncoding::Tree, [1.0, -2.0, 0.5]),
        (&[3, 2, 2, 0], VisibilityEncoding::Table, [0.0; 3]),
        (&[1, 3, 1], VisibilityEncoding::Raw, [0.0; 3]),
        (&[2, 0, 2, 3], VisibilityEncoding::Raw, [-3.0, 0.25, 7.0]),
        (&[3, 3, 2], VisibilityEncoding::Table, [0.5, 0.5, 0.5]),
    ];
    let mut rng = Rng::new(0x5EED_5E11);
    for (case, &(levels, encoding, center)) in cases.iter().enumerate() {
        let patches = [70, 130, 9][case % 3];
        let f = synthetic(levels, patches, center, encoding, 100 + case as u64);
        let pvis = Pvis::parse(&f.bytes).unwrap();
        assert_eq!(pvis.version(), 5);
        assert_eq!(pvis.shell_count() as usize, levels.len() - 1);
        for (s, &level) in levels.iter().enumerate() {
            let shell = pvis.shell(s as u32);
            assert_eq!((shell.level, shell.distance), (level, f.distances[s]));
        }
        let mut scratch = vec![0u64; pvis.scratch_words()];
        let mut stream_scratch = vec![0u64; pvis.scratch_bound()];
        let mut streaming = pvis.streaming(&mut stream_scratch);
        let mut table = vec![0u64; pvis.expanded_bound()];
        let mut expanded = pvis.expand(&mut table);
        let frustum = Frustum::from_planes([
            [1.0, 0.2, 0.0, 0.3],
            [-1.0, 0.0, 0.1, 2.0],
            [0.0, 1.0, 0.0, 1.0],
            [0.0, -1.0, 0.0, 1.5],
            [0.0, 0.0, 1.0, 1.0],
            [0.0, 0.0, -1.0, 2.5],
        ]);
        let mut out = vec![0u64; pvis.row_words()];
        let mut seen = vec![false; levels.len() + 1];
        let mut list = eyes(&f, center, &mut rng);
        // Revisit eyes in another order, so that the streaming paths move back and forth
        // across the shells.
        let again: Vec<[f32; 3]> = (0..list.len())
            .map(|_| list[rng.next_u64() as usize % list.len()])
            .collect();
        list.extend(again);
        for eye in list {
            let (band, expected) = reference(&f, levels, center, eye);
            seen[band as usize] = true;
            let k = levels.len() as u32 - 1;
            let check = |v: &Visible<'_>, mode: &str| {
                assert_eq!(v.bits(), &expected[..], "case {case} {mode} {eye:?}");
                assert_eq!(v.band, band, "case {case} {mode} {eye:?}");
                assert_eq!(v.inside_sphere, band > k, "case {case} {mode} {eye:?}");
                let shells = [band.saturating_sub(1), band.min(k)];
                assert_eq!(v.shells, shells, "case {case} {mode} {eye:?}");
            };
            let stateless = pvis.query(eye, &mut scratch);
            check(&stateless, "stateless");
            let place = stateless.place();
            let d = [0, 1, 2].map(|i| eye[i] - center[i]);
            if d.iter().all(|x| x.is_finite()) {
                for (i, s) in stateless.shells.into_iter().enumerate() {
                    let leaf = locate(d, levels[s as usize]).views;
                    assert_eq!(place.leaves[i], leaf, "case {case} {eye:?}");
                }
            }
            let streamed = streaming.query(eye);
            check(&streamed, "streaming");
            assert_eq!(streamed.place(), place, "case {case} streaming {eye:?}");
            let all = expanded.query(eye);
            check(&all, "expanded");
            assert_eq!(all.place(), place, "case {case} expanded {eye:?}");
            // The frustum variants: the answer less what `Frustum::cull` drops.
            let mut cut = expected.clone();
            frustum.cull(&pvis, &mut cut);
            let v = pvis.query_in_frustum(eye, &frustum, &mut scratch);
            assert_eq!(
                (v.bits(), v.place()),
                (&cut[..], place),
                "case {case} {eye:?}"
            );
            let v = streaming.query_in_frustum(eye, &frustum, &mut out);
            assert_eq!(
                (v.bits(), v.place()),
                (&cut[..], place),
                "case {case} {eye:?}"
            );
            let v = expanded.query_in_frustum(eye, &frustum);
            assert_eq!(
                (v.bits(), v.place()),
                (&cut[..], place),
                "case {case} {eye:?}"
            );
        }
        assert!(seen.iter().all(|&s| s), "case {case}: bands seen {seen:?}");
        // Every view row of every shell, decoded alone and expanded, is the written one.
        for (s, m) in f.rows.iter().enumerate() {
            for v in 0..m.views() {
                pvis.shell_view_row(s as u32, v, &mut out);
                assert_eq!(&out[..], m.row(v), "case {case} shell {s} view {v}");
                assert_eq!(expanded.shell_row(s as u32, v), m.row(v));
            }
        }
    }
}

/// A camera that stays in its leaves costs no decoding, and one moving back and forth across
/// a shell boundary keeps its three paths: after the first crossing, no row is decoded again.
#[test]
fn streaming_keeps_its_paths_across_a_shell_boundary() {
    let levels = [3, 3, 3, 3];
    let f = synthetic(&levels, 100, [0.0; 3], VisibilityEncoding::Tree, 7);
    let pvis = Pvis::parse(&f.bytes).unwrap();
    let mut scratch = vec![0u64; pvis.scratch_bound()];
    let mut streaming = pvis.streaming(&mut scratch);
    let dir = crate::sphere::normalize([0.3, 0.5, 0.8]);
    let at = |r: f32| dir.map(|x| x * r);
    let boundary = f.distances[2];
    let (outside, inside) = (at(boundary * 1.001), at(boundary * 0.999));
    assert_eq!(streaming.query(outside).band, 2);
    assert_eq!(streaming.query(inside).band, 3);
    let decoded = streaming.decoded_rows();
    for _ in 0..10 {
        assert_eq!(streaming.query(outside).band, 2);
        assert_eq!(streaming.query(inside).band, 3);
    }
    assert_eq!(streaming.decoded_rows(), decoded);
}

/// SHEL is meaningful only from version 5: in a version-4 file the same section is an
/// unknown one, ignored, and eyes inside the sampling sphere are `inside_sphere` as before.
#[test]
fn shel_in_an_older_version_is_ignored() {
    let f = synthetic(&[2, 2], 20, [0.0; 3], VisibilityEncoding::Tree, 3);
    let mut bytes = f.bytes.clone();
    bytes[8] = 4;
    let n = bytes.len() - 4;
    let crc = crc32c::crc32c(&bytes[..n]);
    bytes[n..].copy_from_slice(&crc.to_le_bytes());
    let pvis = Pvis::parse(&bytes).unwrap();
    assert_eq!(pvis.shell_count(), 0);
    let mut scratch = vec![0u64; pvis.scratch_words()];
    let v = pvis.query([0.0, 0.0, 2.5], &mut scratch);
    assert!(v.inside_sphere);
    assert_eq!((v.band, v.shells), (1, [0, 0]));
}
