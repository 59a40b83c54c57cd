//! The C ABI called from Rust as C would call it, against conformance vector 002 and its
//! expected dump (so these tests follow the vectors when the format changes).

extern crate std;

use std::ffi::CStr;
use std::format;
use std::string::String;
use std::vec;
use std::vec::Vec;

use super::*;

const VALID: &[u8] = include_bytes!("../../tests/conformance/valid/002-level1-seven-patches.pvis");
const DUMP: &str = include_str!("../../tests/conformance/valid/002-level1-seven-patches.dump");
/// A structured level-3 file whose VISB uses encoding 2 with a real tree.
const TREE: &[u8] =
    include_bytes!("../../tests/conformance/valid/010-level3-300-patches-facing.pvis");
/// A version-5 file with three sampling shells of mixed levels (encoding 2).
const SHELLS: &[u8] = include_bytes!(
    "../../tests/conformance/valid/018-v5-level3-300-patches-three-shells-mixed-levels.pvis"
);
const SHELLS_DUMP: &str = include_str!(
    "../../tests/conformance/valid/018-v5-level3-300-patches-three-shells-mixed-levels.dump"
);
const INVALID: &[u8] =
    include_bytes!("../../tests/conformance/invalid/131-non-contiguous-patch-ranges.pvis");
const INVALID_ERR: &str =
    include_str!("../../tests/conformance/invalid/131-non-contiguous-patch-ranges.err");

/// The value of a `key: value` line of the dump.
fn dump_value(key: &str) -> u64 {
    DUMP.lines()
        .find_map(|l| l.strip_prefix(&format!("{key}: ")))
        .unwrap()
        .parse()
        .unwrap()
}

fn parsed(bytes: &[u8]) -> (i32, PatchvisFile) {
    let mut file = MaybeUninit::<PatchvisFile>::uninit();
    // SAFETY: `bytes` outlives the handle in every test; `file` is writable and aligned.
    let code = unsafe { patchvis_parse(bytes.as_ptr(), bytes.len(), file.as_mut_ptr()) };
    // SAFETY: `patchvis_parse` wrote `state`, and `storage` is `MaybeUninit`.
    (code, unsafe { file.assume_init() })
}

/// `patchvis_query` on a parsed `file` into `scratch`, which must succeed.
fn query_ok(file: &PatchvisFile, eye: &[f32], scratch: &mut [u64]) -> PatchvisVisible {
    assert_eq!(eye.len(), 3);
    let mut visible = MaybeUninit::<PatchvisVisible>::uninit();
    // SAFETY: `file` was parsed from static bytes in every test; `eye` has 3 floats; `scratch`
    // is valid for its length; `visible` is writable.
    let code = unsafe {
        patchvis_query(
            file,
            eye.as_ptr(),
            scratch.as_mut_ptr(),
            scratch.len(),
            visible.as_mut_ptr(),
        )
    };
    assert_eq!(code, PATCHVIS_OK);
    // SAFETY: written by the successful call.
    unsafe { visible.assume_init() }
}

#[test]
fn the_block_is_the_size_the_header_says() {
    assert_eq!(patchvis_file_size(), PATCHVIS_FILE_SIZE);
    assert_eq!(align_of::<PatchvisFile>(), 8);
    // The C header's field layout, computed by hand for LP64.
    assert_eq!(size_of::<PatchvisInfo>(), 72);
    assert_eq!(size_of::<PatchvisVisible>(), 64);
    assert_eq!(size_of::<PatchvisShell>(), 24);
}

/// A version-5 file through the ABI: the shells' records and every query line of its dump,
/// band, shells and both leaves included, from the stateless and the streaming query (eyes
/// near the model, between shells and inside the innermost one).
#[test]
fn shells_and_their_answers_match_the_dump() {
    let (code, file) = parsed(SHELLS);
    assert_eq!(code, PATCHVIS_OK);
    // SAFETY: `file` was parsed from static bytes; outputs are writable.
    let count = unsafe { patchvis_shell_count(&file) };
    assert_eq!(count, 3);
    // SAFETY: as above; null is answered too. Version 5: the sampling sphere is shell 0.
    assert_eq!(unsafe { patchvis_sampling_shell(&file) }, 0);
    assert_eq!(unsafe { patchvis_sampling_shell(core::ptr::null()) }, 0);
    // SAFETY: as above. No far band: no reach.
    assert_eq!(unsafe { patchvis_sampling_reach(&file) }, 0.0);
    assert_eq!(unsafe { patchvis_sampling_reach(core::ptr::null()) }, 0.0);
    let mut shell = PatchvisShell::default();
    for k in 1..=count {
        // SAFETY: as above.
        assert_eq!(unsafe { patchvis_shell(&file, k, &mut shell) }, PATCHVIS_OK);
        let line = format!(
            "shell {k}: distance {} level {} views {} encoding {} bytes {}",
            shell.distance, shell.level, shell.views, shell.encoding, shell.bytes
        );
        assert!(SHELLS_DUMP.lines().any(|l| l == line), "{line}");
    }
    // SAFETY: as above; a shell past K and a null output are refused.
    unsafe {
        assert_eq!(patchvis_shell(&file, 4, &mut shell), PATCHVIS_ERR_RANGE);
        assert_eq!(
            patchvis_shell(&file, 0, core::ptr::null_mut()),
            PATCHVIS_ERR_ARGUMENT
        );
    }
    // SAFETY: as above.
    let words = unsafe { patchvis_scratch_words(&file) };
    let mut scratch = vec![0u64; words];
    let (_stream_scratch, mut stream) = stream_over(&file);
    let mut bands = [false; 5];
    for line in SHELLS_DUMP.lines().filter(|l| l.starts_with("query ")) {
        let position = line["query ".len()..].split(' ').next().unwrap();
        let eye: Vec<f32> = position.split(',').map(|t| t.parse().unwrap()).collect();
        let streamed = stream_query(&mut stream, &eye);
        let visible = query_ok(&file, &eye, &mut scratch);
        let patches: Vec<String> = (0..300u32)
            .filter(|&p| scratch[p as usize / 64] >> (p % 64) & 1 == 1)
            .map(|p| p.to_string())
            .collect();
        let list = |v: &[u32]| {
            let v: Vec<String> = v.iter().map(|x| x.to_string()).collect();
            v.join(",")
        };
        let made = format!(
            "query {position} -> inside {} band {} shells [{}] views [{}] inner [{}] patches [{}]",
            visible.inside_sphere == 1,
            visible.band,
            list(&visible.shells),
            list(&visible.leaf),
            list(&visible.inner_leaf),
            patches.join(",")
        );
        assert_eq!(made, line);
        bands[visible.band as usize] = true;
        assert_eq!(
            (
                streamed.band,
                streamed.shells,
                streamed.leaf,
                streamed.inner_leaf
            ),
            (
                visible.band,
                visible.shells,
                visible.leaf,
                visible.inner_leaf
            )
        );
        assert_eq!(streamed.inside_sphere, visible.inside_sphere);
        // SAFETY: the streamed answer's bits live in the stream's scratch, unused since.
        let bits = unsafe { core::slice::from_raw_parts(streamed.bits, streamed.words) };
        assert_eq!(bits, &scratch[..]);
    }
    assert_eq!(bands, [true; 5]);
}

#[test]
fn info_rows_ranges_and_queries_match_the_dump() {
    let (code, file) = parsed(VALID);
    assert_eq!(code, PATCHVIS_OK);
    let mut info = PatchvisInfo::default();
    // SAFETY: `file` was parsed from `VALID`, which is static.
    assert_eq!(unsafe { patchvis_info(&file, &mut info) }, PATCHVIS_OK);
    assert_eq!(u64::from(info.version), dump_value("version"));
    assert_eq!(info.total_bytes, dump_value("bytes"));
    assert_eq!(u64::from(info.patch_count), dump_value("patches"));
    assert_eq!(info.triangle_count, dump_value("triangles"));
    assert_eq!(u64::from(info.level), dump_value("level"));
    assert_eq!(u64::from(info.views), dump_value("views"));
    // SAFETY: as above.
    let words = unsafe { patchvis_scratch_words(&file) };
    assert_eq!((words, info.scratch_words), (1, 1));

    let mut lines = Vec::new();
    for p in 0..info.patch_count {
        let (mut first, mut count) = (0, 0);
        // SAFETY: as above; both outputs are writable.
        let code = unsafe { patchvis_patch_range(&file, p, &mut first, &mut count) };
        assert_eq!(code, PATCHVIS_OK);
        lines.push(format!("patch {p}: first {first} count {count}"));
    }
    let mut row = vec![0u64; words];
    for v in 0..info.views {
        // SAFETY: as above; `row` holds `words` words.
        let code = unsafe { patchvis_view_row(&file, v, row.as_mut_ptr(), row.len()) };
        assert_eq!(code, PATCHVIS_OK);
        let bits: String = (0..info.patch_count)
            .map(|p| if row[0] >> p & 1 == 1 { '1' } else { '0' })
            .collect();
        lines.push(format!("view {v}: {bits}"));
    }
    let mut scratch = vec![0u64; words];
    for line in DUMP.lines().filter(|l| l.starts_with("query ")) {
        let position = line["query ".len()..].split(' ').next().unwrap();
        let eye: Vec<f32> = position.split(',').map(|t| t.parse().unwrap()).collect();
        let visible = query_ok(&file, &eye, &mut scratch);
        assert_eq!((visible.bits, visible.words), (scratch.as_ptr(), 1));
        let patches: Vec<String> = (0..info.patch_count)
            .filter(|&p| scratch[0] >> p & 1 == 1)
            .map(|p| p.to_string())
            .collect();
        assert_eq!(visible.visible_count as usize, patches.len());
        let [a, b, c] = visible.leaf;
        lines.push(format!(
            "query {position} -> inside {} views [{a},{b},{c}] patches [{}]",
            visible.inside_sphere == 1,
            patches.join(",")
        ));
    }
    let expected: Vec<&str> = DUMP
        .lines()
        .filter(|l| l.starts_with("patch ") || l.starts_with("view ") || l.starts_with("query "))
        .collect();
    assert_eq!(lines, expected);
}

#[test]
fn misuse_is_an_error_code_not_a_panic() {
    let (_, file) = parsed(VALID);
    let mut scratch = [0u64; 1];
    let mut visible = MaybeUninit::<PatchvisVisible>::uninit();
    let eye = [1.0f32, 2.0, 30.0];
    let (mut first, mut count) = (0, 0);
    // SAFETY: every pointer is null or valid as the functions require.
    unsafe {
        assert_eq!(
            patchvis_parse(VALID.as_ptr(), VALID.len(), core::ptr::null_mut()),
            PATCHVIS_ERR_ARGUMENT
        );
        let mut other = MaybeUninit::<PatchvisFile>::uninit();
        assert_eq!(
            patchvis_parse(core::ptr::null(), 5, other.as_mut_ptr()),
            PATCHVIS_ERR_ARGUMENT
        );
        // The handle of a failed parse is marked, so it cannot be queried.
        assert_eq!(patchvis_scratch_words(other.as_ptr()), 0);
        assert_eq!(
            patchvis_info(other.as_ptr(), &mut PatchvisInfo::default()),
            PATCHVIS_ERR_NOT_PARSED
        );
        assert_eq!(patchvis_parse(core::ptr::null(), 0, other.as_mut_ptr()), 1);
        assert_eq!(
            patchvis_info(core::ptr::null(), &mut PatchvisInfo::default()),
            PATCHVIS_ERR_ARGUMENT
        );
        assert_eq!(
            patchvis_info(&file, core::ptr::null_mut()),
            PATCHVIS_ERR_ARGUMENT
        );
        let q = |eye: *const f32, scratch: *mut u64, words, out| {
            patchvis_query(&file, eye, scratch, words, out)
        };
        let (s, v) = (scratch.as_mut_ptr(), visible.as_mut_ptr());
        assert_eq!(q(core::ptr::null(), s, 1, v), PATCHVIS_ERR_ARGUMENT);
        assert_eq!(
            q(eye.as_ptr(), core::ptr::null_mut(), 1, v),
            PATCHVIS_ERR_ARGUMENT
        );
        assert_eq!(
            q(eye.as_ptr(), s, 1, core::ptr::null_mut()),
            PATCHVIS_ERR_ARGUMENT
        );
        assert_eq!(q(eye.as_ptr(), s, 0, v), PATCHVIS_ERR_SCRATCH);
        assert_eq!(q(eye.as_ptr(), s, usize::MAX, v), PATCHVIS_ERR_ARGUMENT);
        assert_eq!(q(eye.as_ptr(), s, 1, v), PATCHVIS_OK);
        assert_eq!(
            patchvis_patch_range(&file, 7, &mut first, &mut count),
            PATCHVIS_ERR_RANGE
        );
        assert_eq!(
            patchvis_patch_range(&file, 0, core::ptr::null_mut(), &mut count),
            PATCHVIS_ERR_ARGUMENT
        );
        assert_eq!(patchvis_view_row(&file, 18, s, 1), PATCHVIS_ERR_RANGE);
        assert_eq!(patchvis_view_row(&file, 0, s, 0), PATCHVIS_ERR_RANGE);
        assert_eq!(
            patchvis_view_row(&file, 0, core::ptr::null_mut(), 1),
            PATCHVIS_ERR_ARGUMENT
        );
    }
}

#[test]
fn refusals_have_codes_and_exact_messages() {
    let (code, file) = parsed(INVALID);
    assert_eq!(code, 17);
    // SAFETY: `file` comes from `patchvis_parse`.
    assert_eq!(unsafe { patchvis_scratch_words(&file) }, 0);
    // SAFETY: the message is a static C string.
    let message = unsafe { CStr::from_ptr(patchvis_error_message(code)) };
    assert_eq!(
        message.to_str().unwrap(),
        "patch triangle ranges are not contiguous"
    );

    let expected = INVALID_ERR.trim_end();
    let mut buf = [0x55 as c_char; 200];
    // SAFETY: `INVALID` is readable; `buf` writable for its length.
    let full = unsafe {
        patchvis_error_detail(INVALID.as_ptr(), INVALID.len(), buf.as_mut_ptr(), buf.len())
    };
    assert_eq!(full, expected.len());
    // SAFETY: NUL-terminated within `buf`.
    let detail = unsafe { CStr::from_ptr(buf.as_ptr()) };
    assert_eq!(detail.to_str().unwrap(), expected);
    // Cut short like snprintf: 9 bytes and a NUL, full length returned.
    let mut short = [0x55 as c_char; 10];
    // SAFETY: as above.
    let full = unsafe {
        patchvis_error_detail(
            INVALID.as_ptr(),
            INVALID.len(),
            short.as_mut_ptr(),
            short.len(),
        )
    };
    assert_eq!(full, expected.len());
    // SAFETY: as above.
    let cut = unsafe { CStr::from_ptr(short.as_ptr()) };
    assert_eq!(cut.to_str().unwrap(), &expected[..9]);
    // SAFETY: a null buffer of length 0 only sizes the message.
    let sized =
        unsafe { patchvis_error_detail(VALID.as_ptr(), VALID.len(), core::ptr::null_mut(), 0) };
    assert_eq!(sized, 2, "\"ok\"");

    // Every code has its own message; unknown codes have one too.
    let codes = [-4, -3, -2, -1, 0]
        .into_iter()
        .chain(FILE_ERRORS.iter().map(|(c, _)| *c));
    let mut seen = std::collections::BTreeSet::new();
    for code in codes {
        // SAFETY: static C strings.
        let m = unsafe { CStr::from_ptr(patchvis_error_message(code)) };
        assert!(
            seen.insert(m.to_bytes().to_vec()),
            "code {code} repeats a message"
        );
    }
    // SAFETY: as above.
    let unknown = unsafe { CStr::from_ptr(patchvis_error_message(1234)) };
    assert_eq!(unknown.to_str().unwrap(), "unknown error code");
}

/// The parts of a refused file's message, as the WebAssembly module's JavaScript gets them:
/// the kind is the file-error code less one, and filling the kind's template with the values
/// gives the reader's exact message.
#[test]
fn error_parts_name_the_template_and_its_values() {
    let mut parts = PatchvisErrorParts::default();
    // SAFETY: `INVALID` is readable; `parts` writable.
    let code = unsafe { patchvis_error_parts(INVALID.as_ptr(), INVALID.len(), &mut parts) };
    assert_eq!(code, 17);
    assert_eq!(parts.kind, 16);
    let error = Pvis::parse(INVALID).unwrap_err();
    assert_eq!(parts.values, error.parts().values);
    let mut values = parts.values.iter();
    let filled: String = crate::runtime::MESSAGE_TEMPLATES[parts.kind as usize]
        .split("{}")
        .enumerate()
        .map(|(i, text)| match i {
            0 => text.into(),
            _ => format!("{}{text}", values.next().unwrap()),
        })
        .collect();
    assert_eq!(filled, INVALID_ERR.trim_end());

    // Every kind's code is its index plus one.
    let bad_magic = *b"NOTAPVIS";
    // SAFETY: as above.
    let code = unsafe { patchvis_error_parts(bad_magic.as_ptr(), bad_magic.len(), &mut parts) };
    assert_eq!((code, parts.kind), (2, 1));

    // A valid file leaves `*out` as it was; misuse is an error code.
    let before = parts;
    // SAFETY: as above.
    assert_eq!(
        unsafe { patchvis_error_parts(VALID.as_ptr(), VALID.len(), &mut parts) },
        PATCHVIS_OK
    );
    assert_eq!(parts, before);
    // SAFETY: null pointers are refused before any access.
    unsafe {
        assert_eq!(
            patchvis_error_parts(VALID.as_ptr(), VALID.len(), core::ptr::null_mut()),
            PATCHVIS_ERR_ARGUMENT
        );
        assert_eq!(
            patchvis_error_parts(core::ptr::null(), 4, &mut parts),
            PATCHVIS_ERR_ARGUMENT
        );
    }
}

#[test]
fn streaming_answers_equal_the_stateless_query() {
    assert_eq!(patchvis_stream_size(), PATCHVIS_STREAM_SIZE);
    assert_eq!(align_of::<PatchvisStream>(), 8);
    for bytes in [VALID, TREE] {
        let (code, file) = parsed(bytes);
        assert_eq!(code, PATCHVIS_OK);
        // SAFETY: `file` was parsed from static bytes.
        let (words, stream_words) = unsafe {
            (
                patchvis_scratch_words(&file),
                patchvis_stream_scratch_words(&file),
            )
        };
        assert!(stream_words >= 4 * words);
        let mut scratch = vec![0u64; words];
        let mut stream_scratch = vec![!0u64; stream_words];
        let mut stream = MaybeUninit::<PatchvisStream>::uninit();
        // SAFETY: too little scratch is refused and marks the state unusable.
        let short = unsafe {
            patchvis_stream_init(
                &file,
                stream_scratch.as_mut_ptr(),
                stream_words - 1,
                stream.as_mut_ptr(),
            )
        };
        assert_eq!(short, PATCHVIS_ERR_SCRATCH);
        let mut out = MaybeUninit::<PatchvisVisible>::uninit();
        // SAFETY: `state` was written; the query must refuse it.
        let refused = unsafe {
            patchvis_stream_query(stream.as_mut_ptr(), [0.0f32; 3].as_ptr(), out.as_mut_ptr())
        };
        assert_eq!(refused, PATCHVIS_ERR_NOT_PARSED);
        // SAFETY: scratch (garbage-filled on purpose) outlives the stream; nothing else uses it.
        let ok = unsafe {
            patchvis_stream_init(
                &file,
                stream_scratch.as_mut_ptr(),
                stream_words,
                stream.as_mut_ptr(),
            )
        };
        assert_eq!(ok, PATCHVIS_OK);
        // An orbit that changes leaf now and then, a far jump, the centre and a NaN eye.
        let mut eyes: Vec<[f32; 3]> = (0..200)
            .map(|i| {
                let t = i as f32 * 0.05;
                [
                    1.0 + 6.0 * t.cos(),
                    2.0 + 0.5 * (3.0 * t).sin(),
                    3.0 + 6.0 * t.sin(),
                ]
            })
            .collect();
        eyes.extend([
            [-50.0, 9.0, 1.0],
            [1.0, 2.0, 3.0],
            [f32::NAN, 0.0, 0.0],
            [7.0, 2.0, 3.0],
        ]);
        for eye in eyes {
            let mut a = MaybeUninit::<PatchvisVisible>::uninit();
            let mut b = MaybeUninit::<PatchvisVisible>::uninit();
            // SAFETY: valid file, scratch, eye and outputs; the stream's borrows are alive.
            unsafe {
                assert_eq!(
                    patchvis_query(
                        &file,
                        eye.as_ptr(),
                        scratch.as_mut_ptr(),
                        words,
                        a.as_mut_ptr()
                    ),
                    PATCHVIS_OK
                );
                assert_eq!(
                    patchvis_stream_query(stream.as_mut_ptr(), eye.as_ptr(), b.as_mut_ptr()),
                    PATCHVIS_OK
                );
            }
            // SAFETY: both were written above; each answer's bits are valid until its scratch
            // is reused.
            let (a, b) = unsafe { (a.assume_init(), b.assume_init()) };
            assert_eq!(
                (a.leaf, a.visible_count, a.inside_sphere),
                (b.leaf, b.visible_count, b.inside_sphere),
                "eye {eye:?}"
            );
            // SAFETY: as above.
            let (ra, rb) = unsafe {
                (
                    core::slice::from_raw_parts(a.bits, a.words),
                    core::slice::from_raw_parts(b.bits, b.words),
                )
            };
            assert_eq!(ra, rb, "eye {eye:?}");
        }
        // SAFETY: null arguments are refused, not dereferenced.
        unsafe {
            assert_eq!(
                patchvis_stream_query(
                    core::ptr::null_mut(),
                    [0.0f32; 3].as_ptr(),
                    out.as_mut_ptr()
                ),
                PATCHVIS_ERR_ARGUMENT
            );
            assert_eq!(
                patchvis_stream_init(
                    &file,
                    core::ptr::null_mut(),
                    stream_words,
                    stream.as_mut_ptr()
                ),
                PATCHVIS_ERR_ARGUMENT
            );
        }
    }
}

/// `patchvis_ranges` gives the ranges of `Pvis::ranges`, in one call, on a version-3 and a
/// version-4 file; a short buffer is `PATCHVIS_ERR_RANGE` with the count needed.
#[test]
fn ranges_come_merged_in_one_call() {
    let compact: &[u8] =
        include_bytes!("../../tests/conformance/valid/016-v4-level3-300-patches-facing.pvis");
    for bytes in [TREE, compact] {
        let (code, file) = parsed(bytes);
        assert_eq!(code, PATCHVIS_OK);
        let pvis = Pvis::parse(bytes).unwrap();
        let mut scratch = vec![0u64; pvis.scratch_words()];
        let mut rust_scratch = vec![0u64; pvis.scratch_words()];
        for eye in [[3.0f32, 1.0, -2.0], [-10.0, 0.5, 4.0], [0.0, 0.0, 50.0]] {
            let visible = query_ok(&file, &eye, &mut scratch);
            let expected: Vec<u32> = pvis
                .ranges(&pvis.query(eye, &mut rust_scratch))
                .flat_map(|(first, count)| [first, count])
                .collect();
            let capacity = pvis.patch_count().div_ceil(2) as usize;
            let (mut out, mut n) = (vec![0u32; 2 * capacity], 0usize);
            // SAFETY: `visible` is this file's answer; `out` holds `2·capacity` words.
            let code =
                unsafe { patchvis_ranges(&file, &visible, out.as_mut_ptr(), capacity, &mut n) };
            assert_eq!(code, PATCHVIS_OK);
            assert_eq!(&out[..2 * n], &expected[..], "eye {eye:?}");
            if n > 1 {
                let mut short = vec![0u32; 2];
                let mut needed = 0usize;
                // SAFETY: as above, with room for one range.
                let code =
                    unsafe { patchvis_ranges(&file, &visible, short.as_mut_ptr(), 1, &mut needed) };
                assert_eq!((code, needed), (PATCHVIS_ERR_RANGE, n));
                assert_eq!(short, expected[..2]);
            }
        }
    }
}

#[test]
fn frustum_queries_match_the_reader_and_refuse_misuse() {
    let (code, file) = parsed(TREE);
    assert_eq!(code, PATCHVIS_OK);
    let pvis = Pvis::parse(TREE).unwrap();
    let words = pvis.scratch_words();
    let s = pvis.sampling();
    // A camera at twice the sampling distance on +X, aimed beside the model: a translation
    // along −X by the distance, a 90° frustum of its own making (x, y within ±w, 0 ≤ z ≤ w).
    let d = 2.0 * s.distance;
    let off = 0.5 * s.radius;
    // Clip x = p.z − c.z − off, y = p.y − c.y, z = w = c.x + d − p.x (looking along −X).
    #[rustfmt::skip]
    let m: [f32; 16] = [
        0.0, 0.0, -1.0, -1.0,
        0.0, 1.0, 0.0, 0.0,
        1.0, 0.0, 0.0, 0.0,
        -s.center[2] - off, -s.center[1], s.center[0] + d, s.center[0] + d,
    ];
    let mut frustum = PatchvisFrustum::default();
    // SAFETY: `m` has 16 floats and `frustum` is writable.
    assert_eq!(
        unsafe {
            patchvis_frustum_from_view_proj(m.as_ptr(), PATCHVIS_DEPTH_ZERO_TO_ONE, &mut frustum)
        },
        PATCHVIS_OK
    );
    let rust = Frustum::from_view_projection(&m, DepthRange::ZeroToOne);
    assert_eq!(frustum.planes, rust.planes());
    // SAFETY: as above; 2 is no depth range, null pointers are refused.
    unsafe {
        assert_eq!(
            patchvis_frustum_from_view_proj(m.as_ptr(), 2, &mut frustum),
            PATCHVIS_ERR_ARGUMENT
        );
        assert_eq!(
            patchvis_frustum_from_view_proj(core::ptr::null(), 0, &mut frustum),
            PATCHVIS_ERR_ARGUMENT
        );
    }

    let eye = [s.center[0] + d, s.center[1], s.center[2]];
    let mut expected = vec![0u64; words];
    let plain = pvis.query(eye, &mut expected).count();
    let culled = pvis.query_in_frustum(eye, &rust, &mut expected).count();
    assert!(culled > 0 && culled < plain, "{culled} of {plain}");

    let mut scratch = vec![0u64; words];
    let mut out = MaybeUninit::<PatchvisVisible>::uninit();
    // SAFETY: every pointer is valid for what the call reads or writes.
    let code = unsafe {
        patchvis_query_frustum(
            &file,
            eye.as_ptr(),
            &frustum,
            scratch.as_mut_ptr(),
            words,
            out.as_mut_ptr(),
        )
    };
    assert_eq!(code, PATCHVIS_OK);
    // SAFETY: written by the successful call.
    let out = unsafe { out.assume_init() };
    assert_eq!((out.visible_count, out.bits), (culled, scratch.as_ptr()));
    assert_eq!(scratch, expected);

    let mut stream_scratch = vec![0u64; pvis.scratch_bound()];
    let mut stream = MaybeUninit::<PatchvisStream>::uninit();
    let mut bits = vec![0u64; words];
    let mut answer = MaybeUninit::<PatchvisVisible>::uninit();
    // SAFETY: as above; the stream's scratch and `bits` are separate buffers.
    unsafe {
        assert_eq!(
            patchvis_stream_init(
                &file,
                stream_scratch.as_mut_ptr(),
                stream_scratch.len(),
                stream.as_mut_ptr()
            ),
            PATCHVIS_OK
        );
        let stream = stream.as_mut_ptr();
        let q =
            |f: *const PatchvisFrustum, n: usize, bits: &mut Vec<u64>, a: *mut PatchvisVisible| {
                patchvis_stream_query_frustum(stream, eye.as_ptr(), f, bits.as_mut_ptr(), n, a)
            };
        assert_eq!(
            q(&frustum, words, &mut bits, answer.as_mut_ptr()),
            PATCHVIS_OK
        );
        assert_eq!(answer.assume_init().bits, bits.as_ptr());
        assert_eq!(bits, expected);
        assert_eq!(
            q(&frustum, words - 1, &mut bits, answer.as_mut_ptr()),
            PATCHVIS_ERR_RANGE
        );
        assert_eq!(
            q(core::ptr::null(), words, &mut bits, answer.as_mut_ptr()),
            PATCHVIS_ERR_ARGUMENT
        );
        assert_eq!(
            patchvis_query_frustum(
                &file,
                eye.as_ptr(),
                &frustum,
                scratch.as_mut_ptr(),
                words - 1,
                answer.as_mut_ptr()
            ),
            PATCHVIS_ERR_SCRATCH
        );
        assert_eq!(
            patchvis_query_frustum(
                &file,
                eye.as_ptr(),
                core::ptr::null(),
                scratch.as_mut_ptr(),
                words,
                answer.as_mut_ptr()
            ),
            PATCHVIS_ERR_ARGUMENT
        );
    }
}

/// A version-6 file (three far shells beyond the sampling distance, two nearer the model)
/// through the ABI: the sampling sphere is shell `J = 3` of `0..=5`, and eyes in every band,
/// from 1000 sampling distances out to the centre, get the Rust reader's answers from the
/// stateless and the streaming query.
#[cfg(feature = "bake")]
#[test]
fn far_band_shells_and_their_answers_are_the_readers() {
    use crate::format::{BakeContents, ShellRows, encode};
    use crate::runtime::Pvis;
    use crate::sampler::{SamplingParams, VisibilityMatrix};
    use crate::tiling::Patch;

    let params = SamplingParams {
        level: 2,
        resolution: 64,
        fov_deg: 60.0,
        center: [0.0; 3],
        radius: 1.5,
    };
    let d = params.distance();
    let patches: Vec<Patch> = (0..70u32)
        .map(|i| Patch {
            first: i,
            count: 1,
            area: 1.0,
            center: [0.0; 3],
            radius: 1.0,
            cone_axis: [0.0; 3],
            cone_cos: -1.0,
        })
        .collect();
    // Each sphere's rows differ: view v of sphere k sees patch p where k + 2 divides v + p + k.
    let rows = |k: u32, level: u32| {
        let views = crate::sphere::view_count(level);
        let mut matrix = VisibilityMatrix::new(views, 70);
        for v in 0..views {
            for p in 0..70 {
                if (v + p + k).is_multiple_of(k + 2) {
                    matrix.set(v, p);
                }
            }
        }
        matrix
    };
    let spheres = [
        (256.0 * d, 1),
        (4.0 * d, 2),
        (2.0 * d, 1),
        (0.8 * d, 2),
        (0.6 * d, 1),
    ];
    let matrices: Vec<VisibilityMatrix> =
        (1..).zip(spheres).map(|(k, (_, l))| rows(k, l)).collect();
    let shells: Vec<ShellRows> = spheres
        .iter()
        .zip(&matrices)
        .map(|(&(distance, _), visibility)| ShellRows {
            distance,
            visibility,
        })
        .collect();
    let sampling = rows(0, params.level);
    let bytes = encode(&BakeContents {
        sampling: &params,
        triangle_count: 70,
        patches: &patches,
        visibility: &sampling,
        shells: &shells,
        // The sampling sphere alone answers out to 1.5·D (of the band out to 2·D).
        reach: 1.5 * d,
    });
    let pvis = Pvis::parse(&bytes).unwrap();
    let (code, file) = parsed(&bytes);
    assert_eq!((code, pvis.version()), (PATCHVIS_OK, 6));
    // SAFETY: `file` was parsed from `bytes`, which outlive it.
    assert_eq!(unsafe { patchvis_sampling_reach(&file) }, 1.5 * d);
    // SAFETY: `file` was parsed from `bytes`, which outlive it; outputs are writable.
    let (count, j) = unsafe { (patchvis_shell_count(&file), patchvis_sampling_shell(&file)) };
    assert_eq!((count, j), (5, 3));
    let mut shell = PatchvisShell::default();
    for s in 0..=count {
        // SAFETY: as above.
        assert_eq!(unsafe { patchvis_shell(&file, s, &mut shell) }, PATCHVIS_OK);
        let expected = match s {
            3 => (d, params.level),
            _ => spheres[s as usize - usize::from(s > 3)],
        };
        assert_eq!((shell.distance, shell.level), expected, "shell {s}");
    }
    // SAFETY: as above.
    let words = unsafe { patchvis_scratch_words(&file) };
    let mut scratch = vec![0u64; words];
    let mut rust_scratch = vec![0u64; words];
    let (_stream_scratch, mut stream) = stream_over(&file);
    let mut bands = [false; 7];
    let radii = [1000.0, 300.0, 30.0, 3.0, 1.5, 1.2, 1.0, 0.9, 0.7, 0.5, 0.0].map(|x| x * d);
    for (i, r) in radii.iter().enumerate() {
        for u in [[0.36f32, 0.48, 0.8], [-0.6, 0.64, -0.48], [0.0, -0.6, 0.8]] {
            let eye = u.map(|x| x * r);
            let expected = pvis.query(eye, &mut rust_scratch);
            let visible = query_ok(&file, &eye, &mut scratch);
            let streamed = stream_query(&mut stream, &eye);
            let place = |v: &PatchvisVisible| (v.band, v.shells, v.leaf, v.inner_leaf);
            let want = (
                expected.band,
                expected.shells,
                expected.leaf,
                expected.inner_leaf,
            );
            assert_eq!(place(&visible), want, "eye {i} at {eye:?}");
            assert_eq!(place(&streamed), want, "eye {i} at {eye:?}");
            assert_eq!(visible.inside_sphere, u32::from(expected.inside_sphere));
            assert_eq!(scratch, expected.bits());
            // SAFETY: the streamed answer's bits live in the stream's scratch, unused since.
            let bits = unsafe { core::slice::from_raw_parts(streamed.bits, streamed.words) };
            assert_eq!(bits, expected.bits());
            bands[visible.band as usize] = true;
        }
    }
    assert_eq!(bands, [true; 7]);
}

/// A streaming state over `file`, initialised, and the scratch it borrows: keep both alive
/// together (moving them moves no borrowed memory: the scratch is on the heap).
fn stream_over(file: &PatchvisFile) -> (Vec<u64>, MaybeUninit<PatchvisStream>) {
    // SAFETY: a parsed file.
    let words = unsafe { patchvis_stream_scratch_words(file) };
    let mut scratch = vec![0u64; words];
    let mut stream = MaybeUninit::<PatchvisStream>::uninit();
    // SAFETY: the scratch outlives the stream (the caller keeps both); nothing else uses it.
    let ok =
        unsafe { patchvis_stream_init(file, scratch.as_mut_ptr(), words, stream.as_mut_ptr()) };
    assert_eq!(ok, PATCHVIS_OK);
    (scratch, stream)
}

/// `patchvis_stream_query` of the state [`stream_over`] made, from `eye`, which must succeed.
fn stream_query(stream: &mut MaybeUninit<PatchvisStream>, eye: &[f32]) -> PatchvisVisible {
    assert_eq!(eye.len(), 3);
    let mut visible = MaybeUninit::<PatchvisVisible>::uninit();
    // SAFETY: the stream was initialised by `stream_over`; `eye` has 3 floats.
    let code =
        unsafe { patchvis_stream_query(stream.as_mut_ptr(), eye.as_ptr(), visible.as_mut_ptr()) };
    assert_eq!(code, PATCHVIS_OK);
    // SAFETY: written by the successful call.
    unsafe { visible.assume_init() }
}
