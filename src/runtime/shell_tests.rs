//! Sampling shells (spec § SHEL, § Query) across the query modes: files with near shells, far
//! shells (version 6's far band) or both, of mixed levels in each encoding, written by
//! `format::encode_with` from known rows, answered by the stateless, streaming and expanded
//! queries (with and without a frustum) and compared with a reference that numbers the spheres
//! and applies the band rule literally to the writer's own rows.

extern crate std;

use std::vec;
use std::vec::Vec;

use super::*;
use crate::format::{BakeContents, ShellRows, VisibilityEncoding, encode_with};
use crate::sphere::{direction, locate, view_count};
use crate::test_kit::rng::Rng;
use crate::tiling::Patch;
use crate::visibility::{SamplingParams, VisibilityMatrix};

/// The sampling distance of every test file: radius 1.5 at a 60° field of view.
const OUTER: f32 = 3.0;

/// One sphere of views as written: its distance, level and rows.
struct Sphere {
    distance: f32,
    level: u32,
    rows: VisibilityMatrix,
}

/// What a test file holds: its bytes, the sampling sphere (CAMR, VISB) and SHEL's records in
/// file order, as written.
struct Synthetic {
    bytes: Vec<u8>,
    sampling: Sphere,
    records: Vec<Sphere>,
    /// SHEL's reach (0: none).
    reach: f32,
}

impl Synthetic {
    /// The file's spheres numbered as spec § SHEL, Numbering has them: by decreasing distance,
    /// the sampling sphere among them. Sorted here, independently of the reader's numbering.
    fn shells(&self) -> Vec<&Sphere> {
        let mut all: Vec<&Sphere> = core::iter::once(&self.sampling)
            .chain(&self.records)
            .collect();
        all.sort_by(|a, b| b.distance.total_cmp(&a.distance));
        all
    }

    /// The number of the sampling sphere among [`Synthetic::shells`].
    fn sampling_shell(&self) -> u32 {
        self.records
            .iter()
            .filter(|r| r.distance > self.sampling.distance)
            .count() as u32
    }
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

/// A file with the sampling sphere at `level` and SHEL records `(distance, level)` in file
/// order (decreasing; beyond [`OUTER`] for the far band), `patches` patches, centred at
/// `center`, in `encoding`, with SHEL's `reach` (0 for none; above [`OUTER`] with a far
/// record).
fn build(
    level: u32,
    records: &[(f32, u32)],
    patches: u32,
    center: [f32; 3],
    encoding: VisibilityEncoding,
    seed: u64,
    reach: f32,
) -> Synthetic {
    let mut rng = Rng::new(seed);
    let params = SamplingParams {
        level,
        resolution: 64,
        fov_deg: 60.0,
        center,
        radius: 1.5,
    };
    assert_eq!(params.distance(), OUTER);
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
    let sampling = Sphere {
        distance: OUTER,
        level,
        rows: rows(level, &axes, 0.0, &mut rng),
    };
    let records: Vec<Sphere> = records
        .iter()
        .map(|&(distance, level)| {
            // Nearer spheres see more; far ones as the sampling sphere does.
            let near = (0.3 * (OUTER - distance) / OUTER).max(0.0);
            Sphere {
                distance,
                level,
                rows: rows(level, &axes, near, &mut rng),
            }
        })
        .collect();
    let shells: Vec<ShellRows> = records
        .iter()
        .map(|r| ShellRows {
            distance: r.distance,
            visibility: &r.rows,
        })
        .collect();
    let contents = BakeContents {
        sampling: &params,
        triangle_count: 2 * u64::from(patches),
        patches: &list,
        visibility: &sampling.rows,
        shells: &shells,
        reach,
    };
    let bytes = encode_with(&contents, encoding);
    Synthetic {
        bytes,
        sampling,
        records,
        reach,
    }
}

/// A file with near shells only (version 5) at `levels[1..]`, the sampling sphere at
/// `levels[0]`: evenly from the sampling distance to just above the radius.
fn synthetic(
    levels: &[u32],
    patches: u32,
    center: [f32; 3],
    encoding: VisibilityEncoding,
    seed: u64,
) -> Synthetic {
    let k = levels.len() - 1;
    let records: Vec<(f32, u32)> = (1..=k)
        .map(|s| {
            let t = s as f32 / k as f32;
            (OUTER + (1.55 - OUTER) * t, levels[s])
        })
        .collect();
    build(levels[0], &records, patches, center, encoding, seed, 0.0)
}

/// Random SHEL records around the sampling sphere at [`OUTER`]: 0–4 far ones (sometimes the
/// outermost at 256 sampling distances or at `f32::MAX`) and 0–4 near ones, 1–8 in all, of
/// levels 0–3, in file order.
fn random_records(rng: &mut Rng) -> Vec<(f32, u32)> {
    let far = (rng.next_u64() % 5) as usize;
    let near = ((rng.next_u64() % 5) as usize).max(usize::from(far == 0));
    let level = |rng: &mut Rng| (rng.next_u64() % 4) as u32;
    let mut distances = Vec::new();
    let mut d = OUTER;
    for _ in 0..far {
        d *= 1.1 + 3.0 * rng.unit() as f32;
        distances.push(d);
    }
    match (far, rng.next_u64() % 3) {
        (0, _) | (_, 0) => {}
        (_, 1) => *distances.last_mut().unwrap() = 256.0 * OUTER,
        _ => *distances.last_mut().unwrap() = f32::MAX,
    }
    distances.reverse();
    let mut inner: Vec<f32> = (0..near)
        .map(|_| 1.5 + (OUTER - 1.5) * rng.unit() as f32)
        .collect();
    inner.sort_by(|a, b| b.total_cmp(a));
    inner.dedup();
    distances.extend(inner.into_iter().filter(|d| (1.5..OUTER).contains(d)));
    if distances.is_empty() {
        distances.push(2.0);
    }
    distances.into_iter().map(|d| (d, level(rng))).collect()
}

/// The spec's answer (§ Query) to `eye`, from the written rows: the band, the answering
/// shells, their leaves and the visible patches.
struct Answer {
    band: u32,
    shells: [u32; 2],
    leaves: Option<[[u32; 3]; 2]>,
    bits: Vec<u64>,
}

/// § Query applied literally: the band from binary64 squares over the spheres numbered by
/// decreasing distance (band `J` within the reach answered by the sampling sphere alone),
/// each answering shell's leaf by `sphere::locate` at its level, and the OR of the written
/// rows of its corners.
fn reference(f: &Synthetic, center: [f32; 3], eye: [f32; 3]) -> Answer {
    let shells = f.shells();
    let words = f.sampling.rows.words_per_row();
    let k = shells.len() as u32 - 1;
    let d = [0, 1, 2].map(|i| eye[i] - center[i]);
    if !d.iter().all(|x| x.is_finite()) {
        let mut all = vec![0u64; words];
        for p in 0..f.sampling.rows.patches() {
            all[p as usize / 64] |= 1 << (p % 64);
        }
        return Answer {
            band: k + 1,
            shells: [k, k],
            leaves: None,
            bits: all,
        };
    }
    let q = (f64::from(d[0]) * f64::from(d[0]) + f64::from(d[1]) * f64::from(d[1]))
        + f64::from(d[2]) * f64::from(d[2]);
    let band = shells
        .iter()
        .filter(|s| q < f64::from(s.distance) * f64::from(s.distance))
        .count() as u32;
    let j = f.sampling_shell();
    let square = |x: f32| f64::from(x) * f64::from(x);
    let answering = match band {
        0 => [0, 0],
        b if b > k => [k, k],
        b if b == j && q < square(f.reach) => [j, j],
        b => [b - 1, b],
    };
    let mut bits = vec![0u64; words];
    let mut leaves = [[0; 3]; 2];
    for (i, s) in answering.into_iter().enumerate() {
        let shell = shells[s as usize];
        leaves[i] = locate(d, shell.level).views;
        for v in leaves[i] {
            for (o, r) in bits.iter_mut().zip(shell.rows.row(v)) {
                *o |= r;
            }
        }
    }
    Answer {
        band,
        shells: answering,
        leaves: Some(leaves),
        bits,
    }
}

/// Eyes in every band: random directions around each sphere (2 % either side) and midway
/// between neighbours, on each sphere along an axis (exactly on it when the centre is the
/// origin), beyond the outermost (twice it, and at 10³⁰ and `f32::MAX` where that is beyond),
/// at the centre, and non-finite.
fn eyes(f: &Synthetic, center: [f32; 3], rng: &mut Rng) -> Vec<[f32; 3]> {
    let distances: Vec<f32> = f.shells().iter().map(|s| s.distance).collect();
    // `(radius, jitter)`.
    let mut radii: Vec<(f32, f32)> = [2.0 * distances[0], 1e30, f32::MAX, 0.0, 1.0]
        .map(|r| (r, 0.02))
        .to_vec();
    if f.reach > 0.0 {
        // Around the reach, exactly on it along an axis, and between it and the sampling sphere.
        radii.push((f.reach, 0.02));
        radii.push((0.5 * f.reach + 0.5 * OUTER, 0.0));
    }
    for w in distances.windows(2) {
        radii.push((0.5 * w[0] + 0.5 * w[1], 0.0));
    }
    radii.extend(distances.iter().map(|&r| (r, 0.02)));
    let mut out = vec![[f32::NAN, 0.0, 0.0], [0.0, f32::INFINITY, 0.0], center];
    for (i, &(r, spread)) in radii.iter().enumerate() {
        for _ in 0..24 {
            let v = [rng.signed(), rng.signed(), rng.signed()];
            let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt().max(1e-3);
            let jitter = 1.0 + spread * rng.signed();
            out.push([0, 1, 2].map(|k| center[k] + v[k] / n * r * jitter));
        }
        let axis = i % 3;
        let mut e = center;
        e[axis] += if i % 2 == 0 { r } else { -r };
        out.push(e);
    }
    out
}

/// Every mode answers every eye of `f` like the reference, its shells are numbered as the spec
/// numbers them, and every row of every shell is the written one. Returns the bands seen.
fn check_file(f: &Synthetic, center: [f32; 3], rng: &mut Rng, case: &str) -> Vec<bool> {
    let shells = f.shells();
    let k = shells.len() as u32 - 1;
    let j = f.sampling_shell();
    let pvis = Pvis::parse(&f.bytes).unwrap();
    assert_eq!(pvis.version(), if j > 0 { 6 } else { 5 }, "{case}");
    assert_eq!(
        (
            pvis.shell_count(),
            pvis.sampling_shell(),
            pvis.sampling_reach()
        ),
        (k, j, f.reach),
        "{case}"
    );
    for (s, sphere) in shells.iter().enumerate() {
        let shell = pvis.shell(s as u32);
        assert_eq!(
            (shell.level, shell.distance),
            (sphere.level, sphere.distance),
            "{case} shell {s}"
        );
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
    let mut seen = vec![false; shells.len() + 1];
    let mut list = eyes(f, center, rng);
    // Revisit eyes in another order, so that the streaming paths move back and forth across
    // the shells.
    let again: Vec<[f32; 3]> = (0..list.len())
        .map(|_| list[rng.next_u64() as usize % list.len()])
        .collect();
    list.extend(again);
    for eye in list {
        let expected = reference(f, center, eye);
        seen[expected.band as usize] = true;
        let check = |v: &Visible<'_>, mode: &str| {
            assert_eq!(v.bits(), &expected.bits[..], "{case} {mode} {eye:?}");
            assert_eq!(v.band, expected.band, "{case} {mode} {eye:?}");
            assert_eq!(v.inside_sphere, expected.band > k, "{case} {mode} {eye:?}");
            assert_eq!(v.shells, expected.shells, "{case} {mode} {eye:?}");
        };
        let stateless = pvis.query(eye, &mut scratch);
        check(&stateless, "stateless");
        let place = stateless.place();
        if let Some(leaves) = expected.leaves {
            assert_eq!(place.leaves, leaves, "{case} {eye:?}");
        }
        let streamed = streaming.query(eye);
        check(&streamed, "streaming");
        assert_eq!(streamed.place(), place, "{case} streaming {eye:?}");
        let all = expanded.query(eye);
        check(&all, "expanded");
        assert_eq!(all.place(), place, "{case} expanded {eye:?}");
        let shared = expanded.query_shared(eye, &mut out);
        check(&shared, "shared");
        assert_eq!(shared.place(), place, "{case} shared {eye:?}");
        // The frustum variants: the answer less what `Frustum::cull` drops.
        let mut cut = expected.bits.clone();
        frustum.cull(&pvis, &mut cut);
        let v = pvis.query_in_frustum(eye, &frustum, &mut scratch);
        assert_eq!((v.bits(), v.place()), (&cut[..], place), "{case} {eye:?}");
        let v = streaming.query_in_frustum(eye, &frustum, &mut out);
        assert_eq!((v.bits(), v.place()), (&cut[..], place), "{case} {eye:?}");
        let v = expanded.query_in_frustum(eye, &frustum);
        assert_eq!((v.bits(), v.place()), (&cut[..], place), "{case} {eye:?}");
    }
    // Every view row of every shell, decoded alone and expanded, is the written one; the
    // sampling sphere's are also `view_row`'s.
    for (s, sphere) in shells.iter().enumerate() {
        for v in 0..sphere.rows.views() {
            pvis.shell_view_row(s as u32, v, &mut out);
            assert_eq!(&out[..], sphere.rows.row(v), "{case} shell {s} view {v}");
            assert_eq!(expanded.shell_row(s as u32, v), sphere.rows.row(v));
        }
    }
    for v in 0..f.sampling.rows.views() {
        pvis.view_row(v, &mut out);
        assert_eq!(&out[..], f.sampling.rows.row(v), "{case} view {v}");
    }
    seen
}

/// Every mode answers every eye like the reference, in files with 1–3 near shells of mixed
/// levels, in each encoding, centred at the origin (eyes exactly on the shells) and off it.
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
        let seen = check_file(&f, center, &mut rng, &format!("case {case}"));
        assert!(seen.iter().all(|&s| s), "case {case}: bands seen {seen:?}");
    }
}

/// The far band (version 6): random mixes of far and near records, 1–8 in all, some with
/// the outermost at 256 sampling distances or at `f32::MAX`, in each encoding, answered like
/// the reference in every band, beyond the outermost shell and exactly on each sphere
/// included.
#[test]
fn far_and_near_shells_answer_like_the_band_rule() {
    let mut rng = Rng::new(0xFA2_BA2D);
    let encodings = [
        VisibilityEncoding::Tree,
        VisibilityEncoding::Raw,
        VisibilityEncoding::Table,
    ];
    let (mut far_files, mut reaches) = (0, 0);
    for case in 0..12 {
        let records = random_records(&mut rng);
        let level = (rng.next_u64() % 4) as u32;
        let center = if case % 3 == 2 {
            [0.75, -1.5, 2.0]
        } else {
            [0.0; 3]
        };
        let patches = [40, 70, 9][case % 3];
        // A reach in every other file with a far band: a fifth to six fifths of the way
        // to the nearest far shell (so sometimes past it).
        let nearest_far = records.iter().rev().find(|r| r.0 > OUTER).map(|r| r.0);
        let reach = match nearest_far {
            Some(far) if case % 2 == 1 => {
                reaches += 1;
                OUTER + (far.min(1e6) - OUTER) * (0.2 + rng.unit() as f32)
            }
            _ => 0.0,
        };
        let f = build(
            level,
            &records,
            patches,
            center,
            encodings[case % 3],
            200 + case as u64,
            reach,
        );
        far_files += usize::from(f.sampling_shell() > 0);
        let name = format!("case {case} {records:?}");
        let seen = check_file(&f, center, &mut rng, &name);
        assert!(seen.iter().all(|&s| s), "{name}: bands seen {seen:?}");
    }
    assert!(far_files >= 6, "{far_files} files with a far band");
    assert!(reaches >= 3, "{reaches} files with a reach");
}

/// The far band's fixed cases: far shells only (the sampling sphere innermost, so its
/// `inside_sphere` eyes are answered by it alone), the maximum of 8 records, and a record at
/// `f32::MAX`.
#[test]
fn far_band_edge_cases_answer_like_the_band_rule() {
    let mut rng = Rng::new(0xED6E);
    let cases: [(&[(f32, u32)], VisibilityEncoding); 3] = [
        (&[(12.0, 2), (6.0, 1)], VisibilityEncoding::Tree),
        (
            &[
                (768.0, 1),
                (24.0, 2),
                (12.0, 0),
                (6.0, 3),
                (2.5, 2),
                (2.25, 1),
                (2.0, 2),
                (1.75, 3),
            ],
            VisibilityEncoding::Table,
        ),
        (
            &[(f32::MAX, 0), (4.0, 2), (2.0, 1)],
            VisibilityEncoding::Raw,
        ),
    ];
    for (case, &(records, encoding)) in cases.iter().enumerate() {
        let f = build(2, records, 30, [0.0; 3], encoding, 300 + case as u64, 0.0);
        let seen = check_file(&f, [0.0; 3], &mut rng, &format!("edge case {case}"));
        assert!(
            seen.iter().all(|&s| s),
            "edge case {case}: bands seen {seen:?}"
        );
    }
    // On the outermost sphere exactly (band 0, that shell alone), just inside it, and a far
    // eye between the sampling sphere and the innermost far shell (both answer).
    let f = build(
        2,
        cases[2].0,
        30,
        [0.0; 3],
        VisibilityEncoding::Raw,
        302,
        0.0,
    );
    let pvis = Pvis::parse(&f.bytes).unwrap();
    let mut scratch = vec![0u64; pvis.scratch_words()];
    let v = pvis.query([f32::MAX, 0.0, 0.0], &mut scratch);
    assert_eq!((v.band, v.shells, v.inside_sphere), (0, [0, 0], false));
    let v = pvis.query([0.0, 0.0, -1e38], &mut scratch);
    assert_eq!((v.band, v.shells), (1, [0, 1]));
    let v = pvis.query([0.0, 3.5, 0.0], &mut scratch);
    assert_eq!((v.band, v.shells), (2, [1, 2]));
    assert_eq!(pvis.sampling_shell(), 2);
}

/// Where SHEL's record `k` (from 1) is in `bytes`.
fn record_offset(bytes: &[u8], k: usize) -> usize {
    let u64_at = |at: usize| u64::from_le_bytes(bytes[at..at + 8].try_into().unwrap());
    let sections = u32::from_le_bytes(bytes[24..28].try_into().unwrap()) as usize;
    let shel = (0..sections)
        .map(|i| 32 + 24 * i)
        .find(|&entry| &bytes[entry..entry + 4] == b"SHEL")
        .map(|entry| u64_at(entry + 8) as usize)
        .unwrap();
    shel + 8 + 16 * (k - 1)
}

/// `bytes` with the `distance` of SHEL record `k` (from 1) and the header's `version` set, and
/// the CRC fixed.
fn with_record_distance(bytes: &[u8], version: u32, k: usize, distance: f32) -> Vec<u8> {
    let mut bytes = bytes.to_vec();
    bytes[8..12].copy_from_slice(&version.to_le_bytes());
    let at = record_offset(&bytes, k);
    bytes[at..at + 4].copy_from_slice(&distance.to_le_bytes());
    let n = bytes.len() - 4;
    let crc = crc32c::crc32c(&bytes[..n]);
    bytes[n..].copy_from_slice(&crc.to_le_bytes());
    bytes
}

/// Whether `bytes` is refused for the distance of SHEL record `k`.
fn refused_at(bytes: &[u8], k: usize) -> bool {
    matches!(
        Pvis::parse(bytes),
        Err(Error::InvalidFloat { what: Rule::ShellDistance, offset, .. })
            if offset == record_offset(bytes, k) as u64
    )
}

/// The distance rules of § SHEL: a record beyond the sampling distance only from version 6;
/// none at it; finite; strictly decreasing across it; none below the radius.
#[test]
fn far_band_distance_rules() {
    // Records at 12, 6 (far) and 2 (near): version 6.
    let far = build(
        1,
        &[(12.0, 1), (6.0, 0), (2.0, 1)],
        10,
        [0.0; 3],
        VisibilityEncoding::Tree,
        9,
        0.0,
    );
    let f = &far.bytes;
    assert_eq!(Pvis::parse(f).unwrap().version(), 6);
    // Labelled version 5, its first record lies beyond the sampling distance.
    assert!(refused_at(&with_record_distance(f, 5, 1, 12.0), 1));
    let near = synthetic(&[1, 1, 0], 10, [0.0; 3], VisibilityEncoding::Tree, 10);
    assert_eq!(Pvis::parse(&near.bytes).unwrap().version(), 5);
    assert!(refused_at(&with_record_distance(&near.bytes, 5, 1, 6.0), 1));
    assert!(refused_at(
        &with_record_distance(&near.bytes, 5, 1, OUTER),
        1
    ));
    // Version 6 reads a file without far records, and a far record up to f32::MAX.
    let relabelled = with_record_distance(&near.bytes, 6, 1, near.records[0].distance);
    let pvis = Pvis::parse(&relabelled).unwrap();
    assert_eq!((pvis.version(), pvis.sampling_shell()), (6, 0));
    let pvis_max = with_record_distance(f, 6, 1, f32::MAX);
    let pvis = Pvis::parse(&pvis_max).unwrap();
    assert_eq!(
        (pvis.shell(0).distance, pvis.sampling_shell()),
        (f32::MAX, 2)
    );
    // At the sampling distance, as the last far record or as the first near one.
    assert!(refused_at(&with_record_distance(f, 6, 2, OUTER), 2));
    assert!(refused_at(&with_record_distance(f, 6, 3, OUTER), 3));
    // Not finite.
    assert!(refused_at(&with_record_distance(f, 6, 1, f32::INFINITY), 1));
    assert!(refused_at(&with_record_distance(f, 6, 1, f32::NAN), 1));
    assert!(refused_at(&with_record_distance(f, 6, 2, f32::NAN), 2));
    // Not decreasing: a far record after a near one, or two equal far ones.
    let near_first = with_record_distance(f, 6, 2, 2.5);
    assert!(refused_at(&with_record_distance(&near_first, 6, 3, 4.0), 3));
    assert!(refused_at(&with_record_distance(f, 6, 2, 12.0), 2));
    // Below the radius.
    assert!(refused_at(&with_record_distance(f, 6, 3, 1.25), 3));
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
    let boundary = f.shells()[2].distance;
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
