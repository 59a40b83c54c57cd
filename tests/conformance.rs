//! Conformance vectors for the `.pvis` format (spec `spec/FORMAT.md`): one `check(path)`
//! driver over `tests/conformance/{valid,invalid}/`, and the generator that made them.
//!
//! - `valid/NNN-name.pvis` + `NNN-name.dump`: the reader must accept the file and its dump
//!   (header fields, every patch, every view's bitfield, query answers for listed positions;
//!   format in `tests/conformance/README.md`) must match byte for byte. Every truncated prefix
//!   and the file plus one trailing byte must be refused.
//! - `invalid/NNN-name.pvis` + `NNN-name.err`: the reader must refuse the file with exactly
//!   that `Error` Display line.
//!
//! The vectors are generated here, by the writer (`format::encode`) from small hand-specified
//! contents, and the invalid ones by targeted corruption of a valid one (with the CRC fixed,
//! so each reaches the check it aims at). Every run also regenerates them in memory and
//! compares with the files, so writer, reader and the committed expectations cannot drift:
//!
//! ```text
//! PATCHVIS_REGENERATE=1 cargo test --test conformance   # rewrite vectors and expectations
//! ```
//!
//! Cost: 107 small vectors; each valid one is parsed once per prefix length (a few thousand
//! parses, each stopping at the length check), well under a second.
#![cfg(feature = "bake")]

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use patchvis::format::{BakeContents, PatchTableLayout, ShellRows, VisibilityEncoding, encode_as};
use patchvis::runtime::consts::{HEADER_LEN, MAGIC, SECTION_ALIGN, SECTION_ENTRY_LEN, TRAILER_LEN};
use patchvis::runtime::crc32c::crc32c;
use patchvis::runtime::{Error, Pvis};
use patchvis::sampler::{SamplingParams, VisibilityMatrix};
use patchvis::sphere;
use patchvis::tiling::Patch;

/// Set to `1` to rewrite the vectors and their expectations from the generator.
const REGENERATE_VAR: &str = "PATCHVIS_REGENERATE";

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/conformance")
}

// ---------------------------------------------------------------------------------------------
// The driver.

/// Checks one vector against its expectation file; `Err` says how it failed.
fn check(path: &Path) -> Result<(), String> {
    let bytes = std::fs::read(path).map_err(|e| format!("cannot read: {e}"))?;
    let kind = path
        .parent()
        .and_then(Path::file_name)
        .and_then(|n| n.to_str());
    match kind {
        Some("valid") => {
            let expected = read_expectation(&path.with_extension("dump"))?;
            let pvis = Pvis::parse(&bytes).map_err(|e| format!("refused a valid vector: {e}"))?;
            let actual = dump(&pvis);
            if actual != expected {
                return Err(format!(
                    "dump differs from {}:\n{}",
                    path.with_extension("dump").display(),
                    first_difference(&expected, &actual)
                ));
            }
            check_prefixes_and_trailing_byte(&bytes)
        }
        Some("invalid") => {
            let expected = read_expectation(&path.with_extension("err"))?;
            match Pvis::parse(&bytes) {
                Ok(_) => Err("accepted an invalid vector".into()),
                Err(e) if format!("{e}\n") == expected => Ok(()),
                Err(e) => Err(format!(
                    "wrong error:\n  expected: {}  actual:   {e}",
                    expected
                )),
            }
        }
        _ => Err("vector is neither in valid/ nor in invalid/".into()),
    }
}

fn read_expectation(path: &Path) -> Result<String, String> {
    std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))
}

/// Every proper prefix of a valid file, and the file plus one byte, must be refused — as
/// truncated or as disagreeing with the header's `file_length` (spec § Header).
fn check_prefixes_and_trailing_byte(bytes: &[u8]) -> Result<(), String> {
    for len in 0..bytes.len() {
        match Pvis::parse(&bytes[..len]) {
            Err(Error::Truncated { .. } | Error::LengthMismatch { .. }) => {}
            Err(e) => return Err(format!("prefix of {len} bytes: unexpected error {e}")),
            Ok(_) => return Err(format!("prefix of {len} bytes was accepted")),
        }
    }
    for extra in [0u8, 0xFF] {
        let mut longer = bytes.to_vec();
        longer.push(extra);
        match Pvis::parse(&longer) {
            Err(Error::LengthMismatch { header, actual })
                if header == bytes.len() as u64 && actual == header + 1 => {}
            other => {
                return Err(format!(
                    "trailing byte {extra:#04x}: expected a length mismatch, got {other:?}"
                ));
            }
        }
    }
    Ok(())
}

fn first_difference(expected: &str, actual: &str) -> String {
    for (i, (e, a)) in expected.lines().zip(actual.lines()).enumerate() {
        if e != a {
            return format!("line {}:\n  expected: {e}\n  actual:   {a}", i + 1);
        }
    }
    format!(
        "expected {} lines, got {}",
        expected.lines().count(),
        actual.lines().count()
    )
}

/// The expected-dump text of a valid file (format: `tests/conformance/README.md`).
fn dump(pvis: &Pvis<'_>) -> String {
    let mut out = String::new();
    let s = pvis.sampling();
    let _ = writeln!(out, "version: {}", pvis.version());
    let _ = writeln!(out, "bytes: {}", pvis.total_bytes());
    let _ = writeln!(out, "patches: {}", pvis.patch_count());
    let _ = writeln!(out, "triangles: {}", pvis.triangle_count());
    let _ = writeln!(out, "level: {}", s.level);
    let _ = writeln!(out, "views: {}", s.views);
    let _ = writeln!(
        out,
        "camera: center {} radius {} distance {} fov {} resolution {}",
        point(s.center),
        s.radius,
        s.distance,
        s.fov_deg,
        s.resolution
    );
    for p in 0..pvis.patch_count() {
        let info = pvis.patch(p);
        let _ = writeln!(
            out,
            "patch {p}: first {} count {}",
            info.first_triangle, info.triangle_count
        );
        let _ = writeln!(
            out,
            "bounds {p}: center {} radius {} cone {} cos {}",
            point(info.center),
            info.radius,
            point(info.cone_axis),
            info.cone_cos
        );
    }
    let k = pvis.shell_count();
    // The sampling sphere is shell `j`; the others are SHEL's records (spec § SHEL, Numbering).
    let j = pvis.sampling_shell();
    let records = || (0..=k).filter(move |&s| s != j);
    if k > 0 {
        let _ = writeln!(out, "shells: {k}");
        if pvis.version() >= 6 {
            let _ = writeln!(out, "sampling shell: {j}");
        }
        if pvis.sampling_reach() != 0.0 {
            let _ = writeln!(out, "sampling reach: {}", pvis.sampling_reach());
        }
        for shell in records() {
            let sh = pvis.shell(shell);
            let _ = writeln!(
                out,
                "shell {shell}: distance {} level {} views {} encoding {} bytes {}",
                sh.distance, sh.level, sh.views, sh.encoding, sh.bytes
            );
        }
    }
    let mut row = vec![0u64; pvis.row_words()];
    let bits = |row: &[u64]| -> String {
        (0..pvis.patch_count())
            .map(|p| {
                if row[p as usize / 64] >> (p % 64) & 1 == 1 {
                    '1'
                } else {
                    '0'
                }
            })
            .collect()
    };
    for view in 0..s.views {
        pvis.view_row(view, &mut row);
        let _ = writeln!(out, "view {view}: {}", bits(&row));
    }
    for shell in records() {
        for view in 0..pvis.shell(shell).views {
            pvis.shell_view_row(shell, view, &mut row);
            let _ = writeln!(out, "shell {shell} view {view}: {}", bits(&row));
        }
    }
    let mut scratch = vec![0u64; pvis.scratch_words()];
    let mut positions = query_positions();
    if k > 0 {
        positions.extend(shell_positions());
    }
    if pvis.version() >= 6 {
        positions.extend(far_positions());
    }
    for eye in positions {
        let visible = pvis.query(eye, &mut scratch);
        let patches: Vec<String> = visible.patches().map(|p| p.to_string()).collect();
        let list = |v: &[u32]| {
            let v: Vec<String> = v.iter().map(|x| x.to_string()).collect();
            v.join(",")
        };
        // Files with shells also say which band and shells answered (README).
        let (band, inner) = if k > 0 {
            (
                format!(" band {} shells [{}]", visible.band, list(&visible.shells)),
                format!(" inner [{}]", list(&visible.inner_leaf)),
            )
        } else {
            (String::new(), String::new())
        };
        let _ = writeln!(
            out,
            "query {},{},{} -> inside {}{band} views [{}]{inner} patches [{}]",
            eye[0],
            eye[1],
            eye[2],
            visible.inside_sphere,
            list(&visible.leaf),
            patches.join(",")
        );
        if k > 0 {
            let _ = writeln!(out, "{}", far_query(pvis, eye));
        }
    }
    out
}

/// The answer of a far-only reader (spec § Far-only readers) to `eye`, as a `far-query` line
/// in the `query` format of a file without shells: § Query's rule on the sampling sphere
/// alone, taken literally from the sampling sphere's rows, with `inside` for every eye nearer
/// than the sampling distance (`q < D²` in binary64, every product exact).
fn far_query(pvis: &Pvis<'_>, eye: [f32; 3]) -> String {
    let s = pvis.sampling();
    let c = s.center;
    let d = [eye[0] - c[0], eye[1] - c[1], eye[2] - c[2]];
    let square = |x: f32| f64::from(x) * f64::from(x);
    let nearer = (square(d[0]) + square(d[1])) + square(d[2]) < square(s.distance);
    let mut answer = vec![0u64; pvis.row_words()];
    let mut row = vec![0u64; pvis.row_words()];
    let (inside, leaf) = if d.iter().all(|x| x.is_finite()) {
        let leaf = sphere::locate(d, s.level).views;
        for view in leaf {
            pvis.view_row(view, &mut row);
            answer.iter_mut().zip(&row).for_each(|(a, r)| *a |= r);
        }
        (nearer, leaf)
    } else {
        for p in 0..pvis.patch_count() {
            answer[p as usize / 64] |= 1 << (p % 64);
        }
        (true, sphere::locate([0.0; 3], s.level).views)
    };
    let list = |v: &mut dyn Iterator<Item = u32>| {
        let v: Vec<String> = v.map(|x| x.to_string()).collect();
        v.join(",")
    };
    format!(
        "far-query {},{},{} -> inside {inside} views [{}] patches [{}]",
        eye[0],
        eye[1],
        eye[2],
        list(&mut leaf.into_iter()),
        list(&mut patchvis::runtime::Patches::of_bits(&answer)),
    )
}

/// The extra eye positions of a file with shells (vectors 017 on, centred at the origin, with
/// the sampling sphere at distance 3): in every band, exactly on the spheres of distance 3,
/// 2.5, 2.25, 2 and 1.75 (on an axis, so `|d|²` is the square exactly: the eye is not inside
/// that sphere), between them and inside the innermost shell.
fn shell_positions() -> Vec<[f32; 3]> {
    vec![
        [3.0, 0.0, 0.0],
        [2.9, 0.0, 0.0],
        [-1.5, 1.5, 1.5],
        [0.0, 2.5, 0.0],
        [0.0, -2.4, 0.0],
        [0.0, -0.0, 2.25],
        [0.0, 2.2, 0.0],
        [0.0, 0.0, -2.0],
        [-1.0, -1.0, -1.2],
        [1.2, 1.0, 0.9],
        [0.0, 0.0, 1.75],
        [1.0, 0.5, -0.5],
        [0.01, -0.02, 0.03],
    ]
}

/// The extra eye positions of a version-6 file (vectors 022 on, centred at the origin with the
/// sampling sphere at distance 3 and far shells among 6, 12, 24 and 768): beyond the outermost
/// far shell (1000 sampling distances out and at 10³⁰), exactly on each of those spheres (on an
/// axis, so the eye is not inside it), just inside and outside the outermost, between far
/// shells, and between the sampling sphere and the innermost far shell.
fn far_positions() -> Vec<[f32; 3]> {
    vec![
        [3000.0, 0.0, 0.0],
        [0.0, 0.0, 1e30],
        [-1e30, 1e30, -1e30],
        [768.0, 0.0, 0.0],
        [0.0, -767.5, 0.0],
        [0.0, 0.0, -768.5],
        [-400.0, 300.0, 0.0],
        [0.0, -24.0, 0.0],
        [10.0, 10.0, -10.0],
        [0.0, 0.0, 12.0],
        [0.0, 0.0, -11.5],
        [-6.0, 0.0, 0.0],
        [5.0, -5.0, 0.5],
        [0.0, 5.9, 0.0],
        [-2.0, -3.0, 2.0],
        [0.0, 0.0, -3.0],
        // Between the sampling distance and 026's reach (3.0625), and exactly on the reach.
        [0.0, 0.0, 3.05],
        [1.75, -1.75, 1.75],
        [0.0, 3.0625, 0.0],
    ]
}

fn point(p: [f32; 3]) -> String {
    format!("[{}, {}, {}]", p[0], p[1], p[2])
}

/// The eye positions every dump lists: the six axes and some diagonals far outside the
/// camera sphere, the sign of zero (spec § Point location: `-0.0` counts as positive), points
/// inside the sphere and at the centre, and non-finite eyes (the conservative answer). Fixed
/// numbers, not derived from the file, so the same line means the same query everywhere.
fn query_positions() -> Vec<[f32; 3]> {
    vec![
        [100.0, 0.0, 0.0],
        [-100.0, 0.0, 0.0],
        [0.0, 100.0, 0.0],
        [0.0, -100.0, 0.0],
        [0.0, 0.0, 100.0],
        [0.0, 0.0, -100.0],
        [-0.0, -0.0, 100.0],
        [30.0, 40.0, 50.0],
        [-25.5, 7.25, -60.0],
        [12.0, -80.0, 3.5],
        [-7.0, -9.0, -11.0],
        [1e30, -1e30, 0.5],
        [1.0, 2.0, 3.0],
        [1.25, 2.5, 3.0],
        [0.0, 0.0, 0.0],
        [f32::NAN, 0.0, 0.0],
        [0.0, f32::INFINITY, 0.0],
    ]
}

// ---------------------------------------------------------------------------------------------
// The generator.

/// Small hand-specified bake contents for one valid vector.
struct ValidSpec {
    name: &'static str,
    level: u32,
    /// Triangles per patch; the patch count is its length.
    counts: Vec<u32>,
    center: [f32; 3],
    radius: f32,
    fov_deg: f32,
    resolution: u32,
    /// Seeds the visibility pattern.
    seed: u64,
    /// Insert an unknown section (tag `XTRA`) between CAMR and PTCH.
    unknown_section: bool,
    /// The VISB encoding: the writer's default (2, context tree), or 0 / 1.
    encoding: VisibilityEncoding,
    /// The patch table: full (version 3 and older, 40-byte records) or compact (version 4).
    layout: PatchTableLayout,
    /// Give patches spread cone axes and let views see the patches facing them (plus a little
    /// noise), so the rows have the structure real bakes have and encoding 2 grows a real tree.
    facing: bool,
    /// Sampling shells: `(distance, level)` each, in the file's order (decreasing distance);
    /// those beyond the sampling distance make it version 6.
    shells: Vec<(f32, u32)>,
    /// Each shell's payload encoding, where they differ from `encoding` (empty: all
    /// `encoding`): the payloads are taken from the file written in each encoding.
    shell_encodings: Vec<VisibilityEncoding>,
    /// SHEL's `reach` (0: none; only with a shell beyond the sampling distance).
    reach: f32,
}

fn valid_specs() -> Vec<ValidSpec> {
    let base = |name, level, counts: Vec<u32>, seed| ValidSpec {
        name,
        level,
        counts,
        center: [1.0, 2.0, 3.0],
        radius: 1.5,
        fov_deg: 60.0,
        resolution: 256,
        seed,
        unknown_section: false,
        encoding: VisibilityEncoding::Tree,
        layout: PatchTableLayout::Full,
        facing: false,
        shells: Vec::new(),
        shell_encodings: Vec::new(),
        reach: 0.0,
    };
    // Versions 5 and 6: sampling shells, around the origin with the sampling sphere at
    // distance 3.
    let v5 = |name, level, counts: Vec<u32>, seed, shells| ValidSpec {
        center: [0.0; 3],
        layout: PatchTableLayout::Compact,
        shells,
        ..base(name, level, counts, seed)
    };
    let v6 = v5;
    vec![
        ValidSpec {
            center: [0.0; 3],
            radius: 1.0,
            fov_deg: 45.0,
            resolution: 1,
            ..base("001-level0-one-patch", 0, vec![1], 1)
        },
        base("002-level1-seven-patches", 1, vec![3, 1, 4, 1, 5, 9, 2], 2),
        base(
            "003-level2-64-patches",
            2,
            (1..=64).map(|i| i % 5 + 1).collect(),
            3,
        ),
        base(
            "004-level2-65-patches",
            2,
            (1..=65).map(|i| i % 3 + 1).collect(),
            4,
        ),
        ValidSpec {
            unknown_section: true,
            ..base("005-unknown-section", 1, vec![2, 2, 2, 2, 2, 2, 2], 5)
        },
        ValidSpec {
            center: [-1000.0, 0.5, 250.0],
            radius: 0.001,
            fov_deg: 179.0,
            resolution: 4096,
            ..base("006-level3-nine-patches-offcentre", 3, vec![7; 9], 6)
        },
        ValidSpec {
            encoding: VisibilityEncoding::Raw,
            ..base(
                "007-level1-seven-patches-raw",
                1,
                vec![3, 1, 4, 1, 5, 9, 2],
                2,
            )
        },
        ValidSpec {
            encoding: VisibilityEncoding::Raw,
            ..base(
                "008-level2-65-patches-raw",
                2,
                (1..=65).map(|i| i % 3 + 1).collect(),
                4,
            )
        },
        ValidSpec {
            encoding: VisibilityEncoding::Table,
            ..base(
                "009-level2-65-patches-table",
                2,
                (1..=65).map(|i| i % 3 + 1).collect(),
                4,
            )
        },
        ValidSpec {
            facing: true,
            ..base(
                "010-level3-300-patches-facing",
                3,
                (1..=300).map(|i| i % 4 + 1).collect(),
                11,
            )
        },
        // Version 4: the compact patch table.
        ValidSpec {
            center: [0.0; 3],
            radius: 1.0,
            fov_deg: 45.0,
            resolution: 1,
            layout: PatchTableLayout::Compact,
            ..base("012-v4-level0-one-patch", 0, vec![1], 1)
        },
        ValidSpec {
            layout: PatchTableLayout::Compact,
            ..base(
                "013-v4-level1-seven-patches",
                1,
                vec![3, 1, 4, 1, 5, 9, 2],
                2,
            )
        },
        ValidSpec {
            layout: PatchTableLayout::Compact,
            ..base(
                "014-v4-level2-130-patches",
                2,
                (1..=130)
                    .map(|i| if i == 70 { 1000 } else { i % 7 + 1 })
                    .collect(),
                4,
            )
        },
        ValidSpec {
            layout: PatchTableLayout::Compact,
            encoding: VisibilityEncoding::Raw,
            ..base(
                "015-v4-level1-seven-patches-raw",
                1,
                vec![3, 1, 4, 1, 5, 9, 2],
                2,
            )
        },
        ValidSpec {
            facing: true,
            layout: PatchTableLayout::Compact,
            ..base(
                "016-v4-level3-300-patches-facing",
                3,
                (1..=300).map(|i| i % 4 + 1).collect(),
                11,
            )
        },
        v5(
            "017-v5-level2-one-shell",
            2,
            (1..=65).map(|i| i % 3 + 1).collect(),
            17,
            vec![(2.0, 2)],
        ),
        ValidSpec {
            facing: true,
            ..v5(
                "018-v5-level3-300-patches-three-shells-mixed-levels",
                3,
                (1..=300).map(|i| i % 4 + 1).collect(),
                18,
                vec![(2.5, 2), (2.0, 3), (1.75, 1)],
            )
        },
        ValidSpec {
            encoding: VisibilityEncoding::Raw,
            ..v5(
                "019-v5-level1-three-shells-raw",
                1,
                vec![3, 1, 4, 1, 5, 9, 2],
                19,
                vec![(2.5, 1), (2.25, 0), (1.75, 2)],
            )
        },
        ValidSpec {
            encoding: VisibilityEncoding::Table,
            ..v5(
                "020-v5-level2-two-shells-table",
                2,
                (1..=65).map(|i| i % 3 + 1).collect(),
                20,
                vec![(2.5, 2), (2.0, 3)],
            )
        },
        // Version 6: the far band.
        v6(
            "022-v6-level2-two-far-shells",
            2,
            (1..=65).map(|i| i % 3 + 1).collect(),
            22,
            vec![(12.0, 2), (6.0, 1)],
        ),
        // The spec's example of § Query: three far shells and two near ones; each payload
        // in another encoding than its neighbours, the far shell at 12 raw.
        ValidSpec {
            facing: true,
            shell_encodings: vec![
                VisibilityEncoding::Tree,
                VisibilityEncoding::Raw,
                VisibilityEncoding::Table,
                VisibilityEncoding::Raw,
                VisibilityEncoding::Tree,
            ],
            ..v6(
                "023-v6-level2-three-far-two-near-mixed-encodings",
                2,
                (1..=40).map(|i| i % 4 + 1).collect(),
                23,
                vec![(768.0, 1), (12.0, 3), (6.0, 2), (2.5, 2), (1.75, 0)],
            )
        },
        ValidSpec {
            encoding: VisibilityEncoding::Raw,
            ..v6(
                "024-v6-level1-raw-far-and-near",
                1,
                vec![3, 1, 4, 1, 5, 9, 2],
                24,
                vec![(768.0, 0), (6.0, 2), (2.25, 1)],
            )
        },
        ValidSpec {
            encoding: VisibilityEncoding::Table,
            ..v6(
                "025-v6-level2-eight-shells",
                2,
                (1..=65).map(|i| i % 3 + 1).collect(),
                25,
                vec![
                    (768.0, 1),
                    (24.0, 2),
                    (12.0, 0),
                    (6.0, 3),
                    (2.5, 2),
                    (2.25, 1),
                    (2.0, 2),
                    (1.75, 3),
                ],
            )
        },
        // SHEL's reach: 023's shells with the spec's example's reach (band 3 nearer than 3.0625
        // answered by the sampling sphere alone), and 022's with a reach past the nearest far
        // shell (all of band 2 so answered).
        ValidSpec {
            reach: 3.0625,
            ..v6(
                "026-v6-level2-sampling-reach",
                2,
                (1..=40).map(|i| i % 4 + 1).collect(),
                26,
                vec![(768.0, 1), (12.0, 3), (6.0, 2), (2.5, 2), (1.75, 0)],
            )
        },
        ValidSpec {
            reach: 7.0,
            ..v6(
                "027-v6-level2-reach-past-the-next-shell",
                2,
                (1..=65).map(|i| i % 3 + 1).collect(),
                27,
                vec![(12.0, 2), (6.0, 1)],
            )
        },
    ]
}

/// A deterministic 64-bit mix (splitmix64's finaliser), for the visibility patterns.
fn mix(mut x: u64) -> u64 {
    x = (x ^ (x >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    x ^ (x >> 31)
}

/// Encodes a spec with the writer (and hand-assembles the extra section where asked).
fn build_valid(spec: &ValidSpec) -> Vec<u8> {
    let params = SamplingParams {
        level: spec.level,
        resolution: spec.resolution,
        fov_deg: spec.fov_deg,
        center: spec.center,
        radius: spec.radius,
    };
    let mut first = 0;
    let patches: Vec<Patch> = spec
        .counts
        .iter()
        .enumerate()
        .map(|(i, &count)| {
            let axis = spec.facing.then(|| {
                let h = mix(spec.seed ^ (i as u64) << 8);
                let c = |k: u32| ((h >> (16 * k)) & 0xFFFF) as f32 / 32768.0 - 1.0;
                let v = [c(0), c(1), c(2)];
                let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt().max(1e-3);
                v.map(|x| x / n)
            });
            let i = i as f32;
            let mut patch = Patch {
                first,
                count,
                area: count as f64,
                center: [i * 0.25, -i * 0.5, 1.0 - i],
                radius: 0.125 * (i + 1.0),
                cone_axis: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, -1.0], [0.0; 3]]
                    [i as usize % 4],
                cone_cos: [-1.0, 0.5, 1.0, 0.0][i as usize % 4],
            };
            if let Some(axis) = axis {
                (patch.cone_axis, patch.cone_cos) = (axis, 0.5);
            }
            first += count;
            patch
        })
        .collect();
    let patch_count = spec.counts.len() as u32;
    // Shell `s` (0 = the sampling sphere) of `level`: nearer shells see more.
    let rows = |s: u64, level: u32| {
        let views = sphere::view_count(level);
        let mut matrix = VisibilityMatrix::new(views, patch_count);
        for view in 0..views {
            for patch in 0..patch_count {
                // View 0 sees everything and view 1 nothing, so both extremes are covered;
                // the rest see about a third of the patches.
                let noise = mix((spec.seed + 1000 * s) << 40 ^ (view as u64) << 20 ^ patch as u64);
                let seen = if spec.facing {
                    let (a, d) = (patches[patch as usize].cone_axis, sphere::direction(view));
                    let near = 0.2 * s as f32;
                    (a[0] * d[0] + a[1] * d[1] + a[2] * d[2] > -0.2 - near)
                        != noise.is_multiple_of(20)
                } else {
                    match view {
                        0 => true,
                        1 => false,
                        _ => noise.is_multiple_of(3 - s.min(1)),
                    }
                };
                if seen {
                    matrix.set(view, patch);
                }
            }
        }
        matrix
    };
    let matrix = rows(0, spec.level);
    let shell_rows: Vec<VisibilityMatrix> = (1..)
        .zip(&spec.shells)
        .map(|(s, &(_, level))| rows(s, level))
        .collect();
    let shells: Vec<ShellRows> = spec
        .shells
        .iter()
        .zip(&shell_rows)
        .map(|(&(distance, _), visibility)| ShellRows {
            distance,
            visibility,
        })
        .collect();
    let contents = BakeContents {
        sampling: &params,
        triangle_count: first as u64,
        patches: &patches,
        visibility: &matrix,
        shells: &shells,
        reach: spec.reach,
    };
    let mut bytes = encode_as(&contents, spec.encoding, spec.layout);
    if !spec.shell_encodings.is_empty() {
        let payloads: Vec<Vec<u8>> = spec
            .shell_encodings
            .iter()
            .enumerate()
            .map(|(k, &encoding)| {
                let other = encode_as(&contents, encoding, spec.layout);
                let (_, shel, _) = find(&other, b"SHEL");
                shel_payloads(&other[shel..])[k].clone()
            })
            .collect();
        bytes = with_shel_payloads(&bytes, &payloads);
    }
    if !spec.unknown_section {
        return bytes;
    }
    let mut sections = sections_of(&bytes);
    sections.insert(
        1,
        (
            *b"XTRA",
            b"an unknown section; version 1 readers skip it".to_vec(),
        ),
    );
    assemble(u32_at(&bytes, 8), &sections)
}

/// The payloads of a SHEL section body, in record order.
fn shel_payloads(shel: &[u8]) -> Vec<Vec<u8>> {
    let count = u32_at(shel, 0) as usize;
    let mut at = 8 + 16 * count;
    (0..count)
        .map(|k| {
            let length = u64_at(shel, 8 + 16 * k + 8) as usize;
            at += length;
            shel[at - length..at].to_vec()
        })
        .collect()
}

/// `bytes` with its SHEL payloads replaced by `payloads` (the records' lengths updated), laid
/// out again.
fn with_shel_payloads(bytes: &[u8], payloads: &[Vec<u8>]) -> Vec<u8> {
    let sections: Vec<_> = sections_of(bytes)
        .into_iter()
        .map(|(tag, body)| {
            if &tag != b"SHEL" {
                return (tag, body);
            }
            let count = u32_at(&body, 0) as usize;
            assert_eq!(count, payloads.len());
            let mut shel = body[..8 + 16 * count].to_vec();
            for (k, payload) in payloads.iter().enumerate() {
                put_u64(&mut shel, 8 + 16 * k + 8, payload.len() as u64);
            }
            shel.extend(payloads.iter().flatten());
            (tag, shel)
        })
        .collect();
    assemble(u32_at(bytes, 8), &sections)
}

/// The sections of a file, in table order: `(tag, body)`.
fn sections_of(bytes: &[u8]) -> Vec<([u8; 4], Vec<u8>)> {
    let count = u32_at(bytes, 24);
    (0..count as usize)
        .map(|i| {
            let entry = HEADER_LEN as usize + i * SECTION_ENTRY_LEN as usize;
            let tag = bytes[entry..entry + 4].try_into().unwrap();
            let offset = u64_at(bytes, entry + 8) as usize;
            let length = u64_at(bytes, entry + 16) as usize;
            (tag, bytes[offset..offset + length].to_vec())
        })
        .collect()
}

/// Lays out a file by hand (spec § File layout): header, table, each section 8-aligned in
/// the given order with zero gaps, CRC-32C trailer.
fn assemble(version: u32, sections: &[([u8; 4], Vec<u8>)]) -> Vec<u8> {
    let table_end = HEADER_LEN + SECTION_ENTRY_LEN * sections.len() as u64;
    let mut offsets = Vec::new();
    let mut end = table_end;
    for (_, body) in sections {
        let offset = end.next_multiple_of(SECTION_ALIGN);
        offsets.push(offset);
        end = offset + body.len() as u64;
    }
    let mut out = Vec::new();
    out.extend_from_slice(&MAGIC);
    out.extend_from_slice(&version.to_le_bytes());
    out.extend_from_slice(&0u32.to_le_bytes());
    out.extend_from_slice(&(end + TRAILER_LEN).to_le_bytes());
    out.extend_from_slice(&(sections.len() as u32).to_le_bytes());
    out.extend_from_slice(&0u32.to_le_bytes());
    for ((tag, body), offset) in sections.iter().zip(&offsets) {
        out.extend_from_slice(tag);
        out.extend_from_slice(&0u32.to_le_bytes());
        out.extend_from_slice(&offset.to_le_bytes());
        out.extend_from_slice(&(body.len() as u64).to_le_bytes());
    }
    for ((_, body), offset) in sections.iter().zip(&offsets) {
        out.resize(*offset as usize, 0);
        out.extend_from_slice(body);
    }
    out.extend_from_slice(&[0; 4]);
    fix_crc(&mut out);
    out
}

fn u32_at(bytes: &[u8], at: usize) -> u32 {
    u32::from_le_bytes(bytes[at..at + 4].try_into().unwrap())
}

fn u64_at(bytes: &[u8], at: usize) -> u64 {
    u64::from_le_bytes(bytes[at..at + 8].try_into().unwrap())
}

fn put_u16(bytes: &mut [u8], at: usize, v: u16) {
    bytes[at..at + 2].copy_from_slice(&v.to_le_bytes());
}

/// Applies `mutate(bytes, visb_offset)` to a file whose VISB uses encoding 2, fixing the CRC;
/// `None` for other encodings.
fn tree_corruption(
    mut bytes: Vec<u8>,
    mutate: impl FnOnce(&mut Vec<u8>, usize),
) -> Option<Vec<u8>> {
    let (_, visb, _) = find(&bytes, b"VISB");
    if u32_at(&bytes, visb) != 2 {
        return None;
    }
    mutate(&mut bytes, visb);
    fix_crc(&mut bytes);
    Some(bytes)
}

fn put_u32(bytes: &mut [u8], at: usize, v: u32) {
    bytes[at..at + 4].copy_from_slice(&v.to_le_bytes());
}

fn put_u64(bytes: &mut [u8], at: usize, v: u64) {
    bytes[at..at + 8].copy_from_slice(&v.to_le_bytes());
}

/// Recomputes the trailer after a deliberate corruption, so the structural check is reached.
fn fix_crc(bytes: &mut [u8]) {
    let n = bytes.len();
    let crc = crc32c(&bytes[..n - TRAILER_LEN as usize]);
    bytes[n - 4..].copy_from_slice(&crc.to_le_bytes());
}

/// Where a section's table entry and body are: `(entry offset, body offset, body length)`.
fn find(bytes: &[u8], tag: &[u8; 4]) -> (usize, usize, usize) {
    let count = u32_at(bytes, 24) as usize;
    (0..count)
        .map(|i| HEADER_LEN as usize + i * SECTION_ENTRY_LEN as usize)
        .find(|&entry| &bytes[entry..entry + 4] == tag)
        .map(|entry| {
            (
                entry,
                u64_at(bytes, entry + 8) as usize,
                u64_at(bytes, entry + 16) as usize,
            )
        })
        .expect("section present")
}

/// A corruption of the base vector; `None` when it does not apply to this file (e.g. a rule
/// of a payload encoding the writer no longer emits).
type Corruption = fn(Vec<u8>) -> Option<Vec<u8>>;

/// The invalid vectors: each corrupts the base vector (valid 002) in one targeted way.
fn invalid_specs() -> Vec<(&'static str, Corruption)> {
    // Mutates, then fixes the CRC so the targeted check is the first to fail.
    fn with_crc(mut bytes: Vec<u8>, mutate: impl FnOnce(&mut Vec<u8>)) -> Option<Vec<u8>> {
        mutate(&mut bytes);
        fix_crc(&mut bytes);
        Some(bytes)
    }
    vec![
        ("101-empty", |_| Some(Vec::new())),
        ("102-bad-magic", |mut b| {
            b[3] = b'X';
            Some(b)
        }),
        ("103-text-mode-magic", |b| {
            // A CR LF → LF conversion, as a text-mode transfer would do.
            let mut out = b[..4].to_vec();
            out.extend_from_slice(&b[5..]);
            Some(out)
        }),
        ("104-version-99", |b| with_crc(b, |b| put_u32(b, 8, 99))),
        ("105-flags-set", |b| with_crc(b, |b| put_u32(b, 12, 1))),
        ("106-wrong-file-length", |b| {
            with_crc(b, |b| {
                let n = b.len() as u64;
                put_u64(b, 16, n + 8)
            })
        }),
        ("107-crc-mismatch", |mut b| {
            let (_, camr, _) = find(&b, b"CAMR");
            b[camr + 32] ^= 0x01; // resolution 256 → 257, trailer left alone
            Some(b)
        }),
        ("108-section-count-zero", |b| {
            with_crc(b, |b| put_u32(b, 24, 0))
        }),
        ("109-section-count-17", |b| {
            with_crc(b, |b| put_u32(b, 24, 17))
        }),
        ("110-header-reserved-set", |b| {
            with_crc(b, |b| put_u32(b, 28, 7))
        }),
        ("111-missing-section", |b| {
            with_crc(b, |b| {
                let (entry, _, _) = find(b, b"PTCH");
                b[entry..entry + 4].copy_from_slice(b"ptch");
            })
        }),
        ("112-duplicate-section", |b| {
            with_crc(b, |b| {
                let (entry, _, _) = find(b, b"VISB");
                b[entry..entry + 4].copy_from_slice(b"PTCH");
            })
        }),
        ("113-overlapping-sections", |b| {
            with_crc(b, |b| {
                let (_, camr, _) = find(b, b"CAMR");
                let (entry, _, _) = find(b, b"PTCH");
                put_u64(b, entry + 8, camr as u64 + 8);
            })
        }),
        ("114-misaligned-offset", |b| {
            with_crc(b, |b| {
                let (entry, ptch, _) = find(b, b"PTCH");
                put_u64(b, entry + 8, ptch as u64 + 4);
            })
        }),
        ("115-section-past-end", |b| {
            with_crc(b, |b| {
                let (entry, _, len) = find(b, b"VISB");
                put_u64(b, entry + 16, len as u64 + 1);
            })
        }),
        ("116-table-reserved-set", |b| {
            with_crc(b, |b| {
                let (entry, _, _) = find(b, b"CAMR");
                put_u32(b, entry + 4, 1);
            })
        }),
        ("117-gap-not-zero", |b| {
            with_crc(b, |b| {
                let (_, camr, len) = find(b, b"CAMR");
                let (_, ptch, _) = find(b, b"PTCH");
                assert!(camr + len < ptch, "the base vector has a gap after CAMR");
                b[camr + len] = 0xAA;
            })
        }),
        ("118-camr-length", |b| {
            with_crc(b, |b| {
                let (entry, _, len) = find(b, b"CAMR");
                put_u64(b, entry + 16, len as u64 - 4);
            })
        }),
        ("119-level-8", |b| {
            with_crc(b, |b| {
                let (_, camr, _) = find(b, b"CAMR");
                put_u32(b, camr, 8);
            })
        }),
        ("120-view-count-mismatch", |b| {
            with_crc(b, |b| {
                let (_, camr, _) = find(b, b"CAMR");
                let views = u32_at(b, camr + 4);
                put_u32(b, camr + 4, views + 1);
            })
        }),
        ("121-non-finite-center", |b| {
            with_crc(b, |b| {
                let (_, camr, _) = find(b, b"CAMR");
                put_u32(b, camr + 12, f32::NAN.to_bits());
            })
        }),
        ("122-non-finite-radius", |b| {
            with_crc(b, |b| {
                let (_, camr, _) = find(b, b"CAMR");
                put_u32(b, camr + 20, f32::INFINITY.to_bits());
            })
        }),
        ("123-zero-radius", |b| {
            with_crc(b, |b| {
                let (_, camr, _) = find(b, b"CAMR");
                put_u32(b, camr + 20, 0.0f32.to_bits());
            })
        }),
        ("124-distance-below-radius", |b| {
            with_crc(b, |b| {
                let (_, camr, _) = find(b, b"CAMR");
                put_u32(b, camr + 24, 1.25f32.to_bits());
            })
        }),
        ("125-fov-180", |b| {
            with_crc(b, |b| {
                let (_, camr, _) = find(b, b"CAMR");
                put_u32(b, camr + 28, 180.0f32.to_bits());
            })
        }),
        ("126-resolution-zero", |b| {
            with_crc(b, |b| {
                let (_, camr, _) = find(b, b"CAMR");
                put_u32(b, camr + 32, 0);
            })
        }),
        ("127-sphere-convention-2", |b| {
            with_crc(b, |b| {
                let (_, camr, _) = find(b, b"CAMR");
                put_u32(b, camr + 36, 2);
            })
        }),
        ("128-patch-count-zero", |b| {
            with_crc(b, |b| {
                let (_, ptch, _) = find(b, b"PTCH");
                put_u32(b, ptch, 0);
            })
        }),
        ("129-patch-count-over-limit", |b| {
            with_crc(b, |b| {
                let (_, ptch, _) = find(b, b"PTCH");
                put_u32(b, ptch, (1 << 20) + 1);
            })
        }),
        ("130-ptch-length", |b| {
            with_crc(b, |b| {
                let (_, ptch, _) = find(b, b"PTCH");
                put_u32(b, ptch, 6);
            })
        }),
        ("131-non-contiguous-patch-ranges", |b| {
            with_crc(b, |b| {
                let (_, ptch, _) = find(b, b"PTCH");
                let first = u32_at(b, ptch + 16 + 40);
                put_u32(b, ptch + 16 + 40, first + 1);
            })
        }),
        ("132-empty-patch", |b| {
            with_crc(b, |b| {
                let (_, ptch, _) = find(b, b"PTCH");
                put_u32(b, ptch + 16 + 4, 0);
            })
        }),
        ("133-triangle-count-mismatch", |b| {
            with_crc(b, |b| {
                let (_, ptch, _) = find(b, b"PTCH");
                let triangles = u64_at(b, ptch + 8);
                put_u64(b, ptch + 8, triangles + 1);
            })
        }),
        ("134-patch-cone-cos-above-1", |b| {
            with_crc(b, |b| {
                let (_, ptch, _) = find(b, b"PTCH");
                put_u32(b, ptch + 16 + 36, 1.5f32.to_bits());
            })
        }),
        ("135-patch-negative-radius", |b| {
            with_crc(b, |b| {
                let (_, ptch, _) = find(b, b"PTCH");
                put_u32(b, ptch + 16 + 40 * 2 + 20, (-0.5f32).to_bits());
            })
        }),
        ("136-visb-encoding-255", |b| {
            with_crc(b, |b| {
                let (_, visb, _) = find(b, b"VISB");
                put_u32(b, visb, 255);
            })
        }),
        ("137-padding-bit-set", |b| {
            // Raw rows (encoding 0) only: the last bit of view 0's one-byte row is padding
            // for 7 patches. Other encodings have their own padding rules.
            let (_, visb, _) = find(&b, b"VISB");
            if u32_at(&b, visb) != 0 {
                return None;
            }
            with_crc(b, |b| b[visb + 8] |= 0x80)
        }),
        ("138-truncated-header", |b| Some(b[..20].to_vec())),
        ("139-truncated-body", |b| Some(b[..b.len() / 2].to_vec())),
        // Encoding 2 (the base vector's): the context tree's rules.
        ("140-tree-node-count-zero", |b| {
            tree_corruption(b, |b, visb| put_u32(b, visb + 8, 0))
        }),
        ("141-tree-node-count-1025", |b| {
            tree_corruption(b, |b, visb| put_u32(b, visb + 8, 1025))
        }),
        ("142-tree-leaf-probability-zero", |b| {
            tree_corruption(b, |b, visb| put_u16(b, visb + 12, 0x8000))
        }),
        ("143-tree-leaf-probability-4096", |b| {
            tree_corruption(b, |b, visb| put_u16(b, visb + 12, 0x9000))
        }),
        ("144-tree-feature-23", |b| {
            tree_corruption(b, |b, visb| put_u16(b, visb + 12, 23 << 10 | 1))
        }),
        ("145-tree-child-not-after-parent", |b| {
            tree_corruption(b, |b, visb| put_u16(b, visb + 12, 3 << 10))
        }),
        ("146-encoding-2-in-version-2", |b| {
            tree_corruption(b, |b, _| put_u32(b, 8, 2))
        }),
    ]
}

/// Sets `n` bits at bit offset `bit` of `bytes` to `value`, least significant first.
fn put_bits(bytes: &mut [u8], bit: usize, n: usize, value: u64) {
    for i in 0..n {
        let (byte, shift) = ((bit + i) / 8, (bit + i) % 8);
        bytes[byte] = bytes[byte] & !(1 << shift) | (((value >> i) & 1) as u8) << shift;
    }
}

/// The compact PTCH of a version-4 vector: `(body offset, widths [count, center, radius,
/// axis, cos], offset of the records)`.
fn compact_ptch(bytes: &[u8]) -> (usize, [usize; 5], usize) {
    let (_, ptch, _) = find(bytes, b"PTCH");
    let w = &bytes[ptch + 32..ptch + 37];
    let patches = u32_at(bytes, ptch) as usize;
    let widths = [w[0], w[1], w[2], w[3], w[4]].map(usize::from);
    (ptch, widths, ptch + 40 + 4 * patches.div_ceil(64))
}

/// The invalid vectors of the compact patch table (version 4): each corrupts valid 013 (or
/// 014, where a rule needs more than 64 patches) in one targeted way.
fn invalid_v4_specs() -> Vec<(&'static str, Corruption)> {
    fn with_crc(mut bytes: Vec<u8>, mutate: impl FnOnce(&mut Vec<u8>)) -> Option<Vec<u8>> {
        mutate(&mut bytes);
        fix_crc(&mut bytes);
        Some(bytes)
    }
    vec![
        ("150-v4-axis-bits-1", |b| {
            with_crc(b, |b| {
                let (ptch, _, _) = compact_ptch(b);
                b[ptch + 35] = 1;
            })
        }),
        ("151-v4-cos-bits-0", |b| {
            with_crc(b, |b| {
                let (ptch, _, _) = compact_ptch(b);
                b[ptch + 36] = 0;
            })
        }),
        ("152-v4-count-bits-33", |b| {
            with_crc(b, |b| {
                let (ptch, _, _) = compact_ptch(b);
                b[ptch + 32] = 33;
            })
        }),
        ("153-v4-reserved-byte-set", |b| {
            with_crc(b, |b| {
                let (ptch, _, _) = compact_ptch(b);
                b[ptch + 38] = 1;
            })
        }),
        ("154-v4-origin-not-finite", |b| {
            with_crc(b, |b| {
                let (ptch, _, _) = compact_ptch(b);
                put_u32(b, ptch + 20, f32::INFINITY.to_bits());
            })
        }),
        ("155-v4-step-zero", |b| {
            with_crc(b, |b| {
                let (ptch, _, _) = compact_ptch(b);
                put_u32(b, ptch + 28, 0);
            })
        }),
        ("156-v4-largest-centre-not-finite", |b| {
            with_crc(b, |b| {
                let (ptch, _, _) = compact_ptch(b);
                put_u32(b, ptch + 28, 3.0e38f32.to_bits());
            })
        }),
        ("157-v4-widths-disagree-with-length", |b| {
            with_crc(b, |b| {
                let (ptch, _, _) = compact_ptch(b);
                b[ptch + 33] += 1;
            })
        }),
        ("158-v4-block-start-wrong", |b| {
            let (ptch, _, _) = compact_ptch(&b);
            if u32_at(&b, ptch) <= 64 {
                return None;
            }
            with_crc(b, |b| {
                let start = u32_at(b, ptch + 44);
                put_u32(b, ptch + 44, start + 1);
            })
        }),
        ("159-v4-axis-coordinate-out-of-range", |b| {
            with_crc(b, |b| {
                let (_, w, records) = compact_ptch(b);
                // Patch 0's first octahedral coordinate: all ones, 2^axis_bits − 1 > 2M.
                let at = records * 8 + w[0] + 3 * w[1] + w[2];
                put_bits(b, at, w[3], (1 << w[3]) - 1);
            })
        }),
        ("160-v4-padding-bits-set", |b| {
            let (ptch, w, records) = compact_ptch(&b);
            let used = u32_at(&b, ptch) as usize * (w[0] + 3 * w[1] + w[2] + 2 * w[3] + w[4]);
            if used.is_multiple_of(8) {
                return None;
            }
            with_crc(b, |b| {
                let last = records + used.div_ceil(8) - 1;
                b[last] |= 0x80;
            })
        }),
        ("161-v4-triangle-count-mismatch", |b| {
            with_crc(b, |b| {
                let (ptch, _, _) = compact_ptch(b);
                let triangles = u64_at(b, ptch + 8);
                put_u64(b, ptch + 8, triangles + 1);
            })
        }),
        ("162-v4-compact-table-in-version-3", |b| {
            with_crc(b, |b| put_u32(b, 8, 3))
        }),
    ]
}

/// The invalid vectors of the SHEL section (version 5): each corrupts valid 018 (three shells,
/// encoding 2) or, for a rule of raw rows, 019 in one targeted way.
fn invalid_v5_specs() -> Vec<(&'static str, Corruption)> {
    /// Replaces the SHEL body with `f(body)` and lays the file out again.
    fn rebuilt(bytes: Vec<u8>, f: impl Fn(Vec<u8>) -> Vec<([u8; 4], Vec<u8>)>) -> Vec<u8> {
        let sections: Vec<_> = sections_of(&bytes)
            .into_iter()
            .flat_map(|(tag, body)| {
                if &tag == b"SHEL" {
                    f(body)
                } else {
                    vec![(tag, body)]
                }
            })
            .collect();
        assemble(u32_at(&bytes, 8), &sections)
    }
    /// Offset of shell `k`'s payload in a SHEL body at `shel`.
    fn payload(bytes: &[u8], shel: usize, k: usize) -> usize {
        let count = u32_at(bytes, shel) as usize;
        let before: u64 = (1..k).map(|j| u64_at(bytes, record(shel, j) + 8)).sum();
        shel + 8 + 16 * count + before as usize
    }
    vec![
        ("170-v5-shell-count-0", |b| {
            in_shel(b, |b, shel| put_u32(b, shel, 0))
        }),
        ("171-v5-shell-count-9", |b| {
            in_shel(b, |b, shel| put_u32(b, shel, 9))
        }),
        ("172-v5-shel-reserved-set", |b| {
            in_shel(b, |b, shel| put_u32(b, shel + 4, 1))
        }),
        ("173-v5-distance-not-below-camr", |b| {
            in_shel(b, |b, shel| put_u32(b, record(shel, 1), 3.0f32.to_bits()))
        }),
        ("174-v5-distances-not-decreasing", |b| {
            in_shel(b, |b, shel| put_u32(b, record(shel, 2), 2.5f32.to_bits()))
        }),
        ("175-v5-distance-below-radius", |b| {
            in_shel(b, |b, shel| put_u32(b, record(shel, 3), 1.4f32.to_bits()))
        }),
        ("176-v5-distance-nan", |b| {
            in_shel(b, |b, shel| put_u32(b, record(shel, 2), f32::NAN.to_bits()))
        }),
        ("177-v5-shell-level-8", |b| {
            in_shel(b, |b, shel| put_u32(b, record(shel, 2) + 4, 8))
        }),
        ("178-v5-lengths-not-summing", |b| {
            in_shel(b, |b, shel| {
                let length = u64_at(b, record(shel, 1) + 8);
                put_u64(b, record(shel, 1) + 8, length + 1);
            })
        }),
        ("179-v5-two-shel-sections", |b| {
            Some(rebuilt(b, |body| {
                vec![(*b"SHEL", body.clone()), (*b"SHEL", body)]
            }))
        }),
        ("180-v5-shel-shorter-than-fixed-part", |b| {
            Some(rebuilt(b, |body| vec![(*b"SHEL", body[..4].to_vec())]))
        }),
        ("181-v5-shel-shorter-than-its-records", |b| {
            Some(rebuilt(b, |body| vec![(*b"SHEL", body[..40].to_vec())]))
        }),
        ("182-v5-payload-unsupported-encoding", |b| {
            in_shel(b, |b, shel| {
                let at = payload(b, shel, 2);
                put_u32(b, at, 3);
            })
        }),
        ("183-v5-payload-reserved-set", |b| {
            in_shel(b, |b, shel| {
                let at = payload(b, shel, 3);
                put_u32(b, at + 4, 1);
            })
        }),
        ("184-v5-payload-tree-node-count-0", |b| {
            in_shel(b, |b, shel| {
                let at = payload(b, shel, 1);
                if u32_at(b, at) == 2 {
                    put_u32(b, at + 8, 0);
                }
            })
        }),
        ("185-v5-shell-level-disagrees-with-payload", |b| {
            in_shel(b, |b, shel| put_u32(b, record(shel, 1) + 4, 3))
        }),
        ("186-v5-raw-payload-padding-bits-set", |b| {
            let (_, shel, _) = find(&b, b"SHEL");
            if u32_at(&b, payload(&b, shel, 1)) != 0 {
                return None;
            }
            in_shel(b, |b, shel| {
                // Shell 1's first row: 7 patches in one byte, bit 7 is padding.
                let at = payload(b, shel, 1);
                b[at + 8] |= 0x80;
            })
        }),
    ]
}

/// Mutates the SHEL body at `shel` (its offset), then fixes the CRC.
fn in_shel(mut bytes: Vec<u8>, mutate: impl FnOnce(&mut Vec<u8>, usize)) -> Option<Vec<u8>> {
    let (_, shel, _) = find(&bytes, b"SHEL");
    mutate(&mut bytes, shel);
    fix_crc(&mut bytes);
    Some(bytes)
}

/// Offset of record `k` (from 1) in a SHEL body at `shel`.
fn record(shel: usize, k: usize) -> usize {
    shel + 8 + 16 * (k - 1)
}

/// The invalid vectors of the far band's distance rules: each corrupts valid 023 (version 6:
/// records at 768, 12, 6, 2.5 and 1.75 around a sampling sphere at 3) or, for the version-5
/// rule, 018 (records at 2.5, 2 and 1.75) in one targeted way.
fn invalid_v6_specs() -> Vec<(&'static str, Corruption)> {
    vec![
        // Version 5 has no far band: a first record beyond the sampling distance is refused.
        ("190-v5-record-beyond-sampling-distance", |b| {
            (u32_at(&b, 8) == 5).then_some(())?;
            in_shel(b, |b, shel| put_u32(b, record(shel, 1), 6.0f32.to_bits()))
        }),
        ("191-v6-record-at-sampling-distance", |b| {
            (u32_at(&b, 8) == 6).then_some(())?;
            in_shel(b, |b, shel| put_u32(b, record(shel, 3), 3.0f32.to_bits()))
        }),
        // A near record (2.75) before a far one (4): not decreasing across the sampling sphere.
        ("192-v6-far-record-after-a-near-one", |b| {
            (u32_at(&b, 8) == 6).then_some(())?;
            in_shel(b, |b, shel| {
                put_u32(b, record(shel, 3), 2.75f32.to_bits());
                put_u32(b, record(shel, 4), 4.0f32.to_bits());
            })
        }),
        ("193-v6-distance-infinite", |b| {
            (u32_at(&b, 8) == 6).then_some(())?;
            in_shel(b, |b, shel| {
                put_u32(b, record(shel, 1), f32::INFINITY.to_bits())
            })
        }),
        ("194-v6-distance-nan", |b| {
            (u32_at(&b, 8) == 6).then_some(())?;
            in_shel(b, |b, shel| put_u32(b, record(shel, 2), f32::NAN.to_bits()))
        }),
        // SHEL's reach: above the sampling distance (3), finite, or 0.
        ("195-v6-reach-at-sampling-distance", |b| {
            (u32_at(&b, 8) == 6).then_some(())?;
            in_shel(b, |b, shel| put_u32(b, shel + 4, 3.0f32.to_bits()))
        }),
        ("196-v6-reach-below-sampling-distance", |b| {
            (u32_at(&b, 8) == 6).then_some(())?;
            in_shel(b, |b, shel| put_u32(b, shel + 4, 2.0f32.to_bits()))
        }),
        ("197-v6-reach-nan", |b| {
            (u32_at(&b, 8) == 6).then_some(())?;
            in_shel(b, |b, shel| put_u32(b, shel + 4, f32::NAN.to_bits()))
        }),
        ("198-v6-reach-negative-zero", |b| {
            (u32_at(&b, 8) == 6).then_some(())?;
            in_shel(b, |b, shel| put_u32(b, shel + 4, (-0.0f32).to_bits()))
        }),
        ("199-v6-reach-infinite", |b| {
            (u32_at(&b, 8) == 6).then_some(())?;
            in_shel(b, |b, shel| put_u32(b, shel + 4, f32::INFINITY.to_bits()))
        }),
    ]
}

/// Every vector the generator makes: `(relative path, bytes)`.
fn generate() -> Vec<(String, Vec<u8>)> {
    let specs = valid_specs();
    let mut out: Vec<(String, Vec<u8>)> = specs
        .iter()
        .map(|spec| (format!("valid/{}.pvis", spec.name), build_valid(spec)))
        .collect();
    let base = out
        .iter()
        .find(|(name, _)| name.contains("002-"))
        .map(|(_, bytes)| bytes.clone())
        .expect("base vector 002");
    // Corruptions that only apply to raw rows (encoding 0) start from the raw twin of 002.
    let raw_base = out
        .iter()
        .find(|(name, _)| name.contains("007-"))
        .map(|(_, bytes)| bytes.clone())
        .expect("base vector 007");
    for (name, corrupt) in invalid_specs() {
        if let Some(bytes) = corrupt(base.clone()).or_else(|| corrupt(raw_base.clone())) {
            out.push((format!("invalid/{name}.pvis"), bytes));
        }
    }
    let compact = |prefix: &str| {
        out.iter()
            .find(|(name, _)| name.contains(prefix))
            .map(|(_, bytes)| bytes.clone())
            .expect("a version-4 base vector")
    };
    let (v4_base, v4_blocks) = (compact("013-v4"), compact("014-v4"));
    let (v5_base, v5_raw, v5_one) = (compact("018-v5"), compact("019-v5"), compact("017-v5"));
    let v6_base = compact("023-v6");
    for (name, corrupt) in invalid_v4_specs() {
        let bytes = corrupt(v4_base.clone())
            .or_else(|| corrupt(v4_blocks.clone()))
            .unwrap_or_else(|| panic!("{name} applies to neither version-4 base"));
        out.push((format!("invalid/{name}.pvis"), bytes));
    }
    for (name, corrupt) in invalid_v5_specs() {
        let bytes = corrupt(v5_base.clone())
            .or_else(|| corrupt(v5_raw.clone()))
            .unwrap_or_else(|| panic!("{name} applies to neither version-5 base"));
        out.push((format!("invalid/{name}.pvis"), bytes));
    }
    for (name, corrupt) in invalid_v6_specs() {
        let bytes = corrupt(v6_base.clone())
            .or_else(|| corrupt(v5_base.clone()))
            .unwrap_or_else(|| panic!("{name} applies to neither base"));
        out.push((format!("invalid/{name}.pvis"), bytes));
    }
    // A SHEL section in a version-4 file is an unknown section (spec § SHEL): 017 relabelled
    // as version 4 is valid, without shells.
    let mut v4_with_shel = v5_one;
    put_u32(&mut v4_with_shel, 8, 4);
    fix_crc(&mut v4_with_shel);
    out.push((
        "valid/021-v4-shel-section-ignored.pvis".into(),
        v4_with_shel,
    ));
    // The tree's depth limit, from both sides: 002's VISB replaced by a chain of internal
    // nodes exactly MAX_TREE_DEPTH deep (valid; every walk of a set feature goes deep) and
    // one deeper (refused).
    for (name, depth) in [
        ("valid/011-level1-tree-depth-32", 32),
        ("invalid/147-tree-depth-33", 33),
    ] {
        let sections: Vec<_> = sections_of(&base)
            .into_iter()
            .map(|(tag, body)| {
                let body = if &tag == b"VISB" {
                    chain_tree_visb(&body, depth)
                } else {
                    body
                };
                (tag, body)
            })
            .collect();
        out.push((
            format!("{name}.pvis"),
            assemble(u32_at(&base, 8), &sections),
        ));
    }
    out.sort_by(|a, b| a.0.cmp(&b.0));
    out
}

/// An encoding-2 VISB body with `original`'s records and a tree that is a chain `depth`
/// internal nodes deep: node `2i` tests feature `i % 23` and leads to leaf `2i + 1` (when the
/// feature is 0) or node `2i + 2`; the leaves hold increasing probabilities of a 0.
fn chain_tree_visb(original: &[u8], depth: u16) -> Vec<u8> {
    let nodes = u32_at(original, 8) as usize;
    let records = &original[12 + 2 * nodes..];
    let mut body = original[..8].to_vec();
    body.extend_from_slice(&(2 * depth as u32 + 1).to_le_bytes());
    for i in 0..depth {
        body.extend_from_slice(&((i % 23) << 10 | (2 * i + 1)).to_le_bytes());
        body.extend_from_slice(&(0x8000u16 | (100 + 100 * i)).to_le_bytes());
    }
    body.extend_from_slice(&(0x8000u16 | 4000).to_le_bytes());
    body.extend_from_slice(records);
    body
}

/// Rewrites every vector and expectation file (the directories are emptied first, so
/// vectors the generator no longer makes disappear).
fn regenerate(vectors: &[(String, Vec<u8>)]) {
    for dir in ["valid", "invalid"] {
        let dir = root().join(dir);
        std::fs::create_dir_all(&dir).unwrap();
        for entry in std::fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            if matches!(
                path.extension().and_then(|e| e.to_str()),
                Some("pvis" | "dump" | "err")
            ) {
                std::fs::remove_file(path).unwrap();
            }
        }
    }
    for (name, bytes) in vectors {
        let path = root().join(name);
        std::fs::write(&path, bytes).unwrap();
        let (expectation, text) = match Pvis::parse(bytes) {
            Ok(pvis) => (path.with_extension("dump"), dump(&pvis)),
            Err(e) => (path.with_extension("err"), format!("{e}\n")),
        };
        let expected_dir = if name.starts_with("valid/") {
            "dump"
        } else {
            "err"
        };
        assert_eq!(
            expectation.extension().unwrap(),
            expected_dir,
            "{name}: the reader's verdict disagrees with the generator's intent"
        );
        std::fs::write(expectation, text).unwrap();
    }
}

/// The vector files on disk, sorted.
fn vector_files() -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = ["valid", "invalid"]
        .iter()
        .flat_map(|dir| std::fs::read_dir(root().join(dir)).unwrap())
        .map(|entry| entry.unwrap().path())
        .filter(|path| path.extension().is_some_and(|e| e == "pvis"))
        .collect();
    files.sort();
    files
}

#[test]
fn conformance_vectors() {
    let generated = generate();
    if std::env::var_os(REGENERATE_VAR).is_some_and(|v| v == "1") {
        regenerate(&generated);
    }
    let mut failures = Vec::new();

    // The files must be exactly what the writer and generator make today.
    for (name, bytes) in &generated {
        match std::fs::read(root().join(name)) {
            Ok(stored) if &stored == bytes => {}
            Ok(_) => failures.push(format!("{name}: differs from what the generator makes")),
            Err(e) => failures.push(format!("{name}: {e}")),
        }
    }
    let files = vector_files();
    if files.len() != generated.len() {
        failures.push(format!(
            "{} vector files on disk, the generator makes {}",
            files.len(),
            generated.len()
        ));
    }

    for path in &files {
        if let Err(why) = check(path) {
            failures.push(format!("{}: {why}", path.display()));
        }
    }
    assert!(
        failures.is_empty(),
        "{} conformance failures (after an intended format change, run \
         `{REGENERATE_VAR}=1 cargo test --test conformance` and review the diff):\n{}",
        failures.len(),
        failures.join("\n")
    );
}

/// Version 4 changes the patch table only: each version-4 vector made from the same contents
/// as an older one has the same ranges, rows and query answers (issue 23: "query answers'
/// patch sets unchanged").
#[test]
fn version_4_answers_like_the_full_table() {
    let vectors = generate();
    let bytes = |prefix: &str| {
        &vectors
            .iter()
            .find(|(name, _)| name.starts_with(&format!("valid/{prefix}")))
            .expect("vector")
            .1
    };
    let same = |line: &str| {
        line.starts_with("patch ") || line.starts_with("view ") || line.starts_with("query ")
    };
    for (old, new) in [
        ("001", "012"),
        ("002", "013"),
        ("007", "015"),
        ("010", "016"),
    ] {
        let (a, b) = (
            Pvis::parse(bytes(old)).unwrap(),
            Pvis::parse(bytes(new)).unwrap(),
        );
        assert_eq!((a.version() < 4, b.version()), (true, 4), "{old} / {new}");
        let (a, b) = (dump(&a), dump(&b));
        let (a, b): (Vec<&str>, Vec<&str>) = (
            a.lines().filter(|l| same(l)).collect(),
            b.lines().filter(|l| same(l)).collect(),
        );
        assert!(a.iter().any(|l| l.starts_with("query ")));
        assert_eq!(a, b, "vectors {old} and {new}");
    }
}

/// The driver itself must catch a wrong dump, a wrong error and an accepted invalid file.
#[test]
fn check_detects_wrong_expectations() {
    let dir = tempfile::tempdir().unwrap();
    let valid = dir.path().join("valid");
    let invalid = dir.path().join("invalid");
    std::fs::create_dir_all(&valid).unwrap();
    std::fs::create_dir_all(&invalid).unwrap();
    let bytes = build_valid(&valid_specs()[1]);
    let pvis = Pvis::parse(&bytes).unwrap();

    std::fs::write(valid.join("a.pvis"), &bytes).unwrap();
    std::fs::write(valid.join("a.dump"), dump(&pvis)).unwrap();
    assert_eq!(check(&valid.join("a.pvis")), Ok(()));
    std::fs::write(
        valid.join("a.dump"),
        dump(&pvis).replace("view 3:", "view 4:"),
    )
    .unwrap();
    assert!(check(&valid.join("a.pvis")).unwrap_err().contains("view 3"));

    std::fs::write(invalid.join("b.pvis"), &bytes).unwrap();
    std::fs::write(invalid.join("b.err"), "anything\n").unwrap();
    assert_eq!(
        check(&invalid.join("b.pvis")),
        Err("accepted an invalid vector".into())
    );
    std::fs::write(invalid.join("b.pvis"), &bytes[..bytes.len() - 1]).unwrap();
    assert!(
        check(&invalid.join("b.pvis"))
            .unwrap_err()
            .starts_with("wrong error")
    );
}
