//! C ABI over the runtime reader (feature `capi`): parse a `.pvis` held in caller memory, then
//! query it, with no allocation. Header: `include/patchvis.h`; example: `tests/c/query.c`.
//!
//! Design: the caller allocates a [`PatchvisFile`] (a fixed [`PATCHVIS_FILE_SIZE`]-byte,
//! 8-aligned block, e.g. on the stack) and [`patchvis_parse`] stores the validated reader
//! (`runtime::Pvis`, a few slices into the caller's bytes) in it, plus a marker saying the
//! parse succeeded. Later calls check the marker, then borrow the reader back. So a query
//! costs what `Pvis::query` costs — no re-validation — and nothing is ever freed.
//!
//! **Lifetime rule:** the bytes passed to `patchvis_parse` must stay valid and unmodified for
//! as long as the `PatchvisFile` is used; a query's answer lives in the caller's scratch.
//!
//! **Streaming:** a [`PatchvisStream`] ([`PATCHVIS_STREAM_SIZE`] bytes, caller memory) holds a
//! `runtime::Streaming` over caller scratch (`patchvis_stream_init`), so engines get the
//! cached-path queries (tens of nanoseconds while the camera stays in its leaf) through C too;
//! `patchvis_query` stays the stateless, scratch-light call.
//!
//! **No panics across the boundary.** `catch_unwind` needs std, and the reader is `no_std`; so
//! every function is panic-free by construction: each caller contract the Rust API `assert!`s
//! (patch and view in range, scratch large enough) is checked here first and reported as an
//! error code. Every `unsafe` block is a raw-pointer access whose contract the function's
//! `# Safety` section hands to the C caller. The reader itself keeps `forbid(unsafe_code)`.
//!
//! Return codes: 0 success; negative for a misuse of the API (`PATCHVIS_ERR_*` below); positive
//! for a file the reader refused, one code per kind of `runtime::Error`.
//!
//! Building: `cargo rustc --release --lib --no-default-features --features capi,std
//! --crate-type staticlib` gives `libpatchvis.a` (the normal build stays an rlib only; see
//! `tests/c/run.sh`).

use core::ffi::c_char;
use core::mem::{MaybeUninit, align_of, size_of};
use core::ptr::{addr_of, addr_of_mut};

use crate::runtime::{DepthRange, Error, Frustum, Pvis, Streaming};

/// The panic handler of the `no_std` WebAssembly build (feature `wasm`, a `cdylib` for
/// `wasm32-unknown-unknown`). Nothing through this ABI panics (see above), so it only
/// traps, which the JavaScript host sees as a `WebAssembly.RuntimeError`.
#[cfg(all(
    feature = "wasm",
    target_arch = "wasm32",
    not(feature = "std"),
    not(test)
))]
#[panic_handler]
fn panic(_: &core::panic::PanicInfo<'_>) -> ! {
    core::arch::wasm32::unreachable()
}

/// Size in bytes of [`PatchvisFile`]; the header's `PATCHVIS_FILE_SIZE`.
pub const PATCHVIS_FILE_SIZE: usize = 512;

/// Words of [`PatchvisFile::storage`]: the whole block less the marker word.
const STORAGE_WORDS: usize = PATCHVIS_FILE_SIZE / 8 - 1;

/// Marker in [`PatchvisFile::state`] after a successful parse (`"PVISOK"` and a 1).
const STATE_PARSED: u64 = 0x5056_4953_4F4B_0001;

// The reader must fit the caller's block, at no stricter alignment than the block's. Growing
// `Pvis` past it (a later format version) fails here, at compile time, not in a C program.
const _: () = assert!(size_of::<Pvis<'static>>() <= STORAGE_WORDS * size_of::<u64>());
const _: () = assert!(align_of::<Pvis<'static>>() <= align_of::<u64>());

/// Size in bytes of [`PatchvisStream`]; the header's `PATCHVIS_STREAM_SIZE`.
pub const PATCHVIS_STREAM_SIZE: usize = 8192;

/// Words of [`PatchvisStream::storage`].
const STREAM_WORDS: usize = PATCHVIS_STREAM_SIZE / 8 - 1;

/// Marker in [`PatchvisStream::state`] after a successful `patchvis_stream_init`.
const STATE_STREAMING: u64 = 0x5056_4953_5354_0001;

const _: () = assert!(size_of::<Streaming<'static, 'static>>() <= STREAM_WORDS * size_of::<u64>());
const _: () = assert!(align_of::<Streaming<'static, 'static>>() <= align_of::<u64>());

/// Success.
pub const PATCHVIS_OK: i32 = 0;
/// A null pointer where one is required, or a length past `isize::MAX`.
pub const PATCHVIS_ERR_ARGUMENT: i32 = -1;
/// The `PatchvisFile` is not from a successful `patchvis_parse`.
pub const PATCHVIS_ERR_NOT_PARSED: i32 = -2;
/// The scratch buffer is shorter than `patchvis_scratch_words`.
pub const PATCHVIS_ERR_SCRATCH: i32 = -3;
/// A patch or view index past the end, or an output buffer too short for a row.
pub const PATCHVIS_ERR_RANGE: i32 = -4;

/// Codes for the reader's refusals, one per kind of [`Error`], in its declaration order.
const FILE_ERRORS: [(i32, &core::ffi::CStr); 21] = [
    (1, c"truncated"),
    (2, c"not a .pvis file (bad signature)"),
    (3, c"unsupported format version"),
    (4, c"unknown header flags"),
    (5, c"file length disagrees with the header"),
    (6, c"checksum mismatch"),
    (7, c"a required section is missing"),
    (8, c"a section appears twice"),
    (9, c"a section is shorter than its fixed part"),
    (10, c"a section has the wrong length"),
    (11, c"a section lies outside its allowed bytes"),
    (12, c"a section offset is misaligned"),
    (13, c"a resource limit is exceeded"),
    (14, c"an integer field breaks a rule of the format"),
    (15, c"a float field breaks a rule of the format"),
    (16, c"view count disagrees with the sphere level"),
    (17, c"patch triangle ranges are not contiguous"),
    (18, c"patch ranges do not sum to the triangle count"),
    (19, c"unsupported visibility encoding"),
    (20, c"padding bits set in a visibility row"),
    (99, c"invalid file"),
];

/// The code of a reader error (see `FILE_ERRORS`).
fn file_error_code(error: &Error) -> i32 {
    match error {
        Error::Truncated { .. } => 1,
        Error::BadMagic => 2,
        Error::UnsupportedVersion { .. } => 3,
        Error::UnknownFlags { .. } => 4,
        Error::LengthMismatch { .. } => 5,
        Error::ChecksumMismatch { .. } => 6,
        Error::MissingSection { .. } => 7,
        Error::DuplicateSection { .. } => 8,
        Error::BadSection { .. } => 9,
        Error::SectionLength { .. } => 10,
        Error::SectionOutOfBounds { .. } => 11,
        Error::SectionMisaligned { .. } => 12,
        Error::LimitExceeded { .. } => 13,
        Error::Invalid { .. } => 14,
        Error::InvalidFloat { .. } => 15,
        Error::ViewCountMismatch { .. } => 16,
        Error::PatchRange { .. } => 17,
        Error::TriangleCountMismatch { .. } => 18,
        Error::UnsupportedEncoding { .. } => 19,
        Error::PaddingBits { .. } => 20,
        // Kinds a later reader adds keep working through the C ABI, if less precisely.
        #[allow(unreachable_patterns)]
        _ => 99,
    }
}

/// A parsed file, in memory the caller provides. Opaque: only the functions here read it.
#[repr(C)]
pub struct PatchvisFile {
    /// [`STATE_PARSED`] once `patchvis_parse` succeeded, 0 after it failed.
    state: u64,
    /// Holds a `Pvis` when `state` says so.
    storage: [MaybeUninit<u64>; STORAGE_WORDS],
}

/// What a file holds (spec § Header, § CAMR, § PTCH).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PatchvisInfo {
    /// Format version.
    pub version: u32,
    /// Number of patches (at least 1).
    pub patch_count: u32,
    /// Number of triangles the patches cover.
    pub triangle_count: u64,
    /// Sphere subdivision level.
    pub level: u32,
    /// Number of views, `4·4^level + 2`.
    pub views: u32,
    /// Centre of the bounding sphere.
    pub center: [f32; 3],
    /// Radius of the bounding sphere.
    pub radius: f32,
    /// Camera distance from the centre.
    pub distance: f32,
    /// Full field of view of the sampling cameras, degrees.
    pub fov_deg: f32,
    /// ID-buffer resolution, pixels per side.
    pub resolution: u32,
    /// Length of the file in bytes.
    pub total_bytes: u64,
    /// `u64` words of scratch a query needs (`patchvis_scratch_words`).
    pub scratch_words: usize,
}

/// The answer to a query (spec § Query). `bits` points into the caller's scratch.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PatchvisVisible {
    /// The visible set: bit `p % 64` of word `p / 64` is patch `p`; bits past the last patch
    /// are zero.
    pub bits: *const u64,
    /// Words at `bits`: `ceil(patch_count / 64)`.
    pub words: usize,
    /// The three views whose rows were combined.
    pub leaf: [u32; 3],
    /// Number of visible patches.
    pub visible_count: u32,
    /// 1 if the eye is inside the innermost shell (the sampling sphere for a file without
    /// shells): the answer is then approximate, and a renderer may prefer to draw everything.
    pub inside_sphere: u32,
    /// How many shells the eye is strictly inside, the sampling sphere counted among them:
    /// `0..=K + 1` (`runtime::Visible::band`).
    pub band: u32,
    /// The shells whose rows were combined, outer first; the same shell twice where one
    /// answered (`runtime::Visible::shells`).
    pub shells: [u32; 2],
    /// The three views of shell `shells[1]` whose rows were combined; `leaf` is of
    /// `shells[0]`.
    pub inner_leaf: [u32; 3],
}

impl PatchvisVisible {
    /// The C description of a query's answer; `bits` points into the answer's scratch.
    fn of(visible: &crate::runtime::Visible<'_>) -> Self {
        PatchvisVisible {
            bits: visible.bits().as_ptr(),
            words: visible.bits().len(),
            leaf: visible.leaf,
            visible_count: visible.count(),
            inside_sphere: u32::from(visible.inside_sphere),
            band: visible.band,
            shells: visible.shells,
            inner_leaf: visible.inner_leaf,
        }
    }
}

/// A byte slice from C, or `None` for a null pointer with a non-zero length or a length past
/// what a Rust slice may span.
///
/// # Safety
/// Unless null, `data` must be valid for reads of `len` bytes, unmodified for `'a`.
unsafe fn bytes<'a>(data: *const u8, len: usize) -> Option<&'a [u8]> {
    if len > isize::MAX as usize {
        return None;
    }
    if data.is_null() {
        return if len == 0 { Some(&[]) } else { None };
    }
    // SAFETY: non-null, and the caller guarantees `len` readable bytes that outlive `'a`.
    Some(unsafe { core::slice::from_raw_parts(data, len) })
}

/// The reader stored in `file`, or the code saying why there is none.
///
/// # Safety
/// Unless null, `file` must point to a `PatchvisFile` that was passed to `patchvis_parse`,
/// whose bytes are still valid for `'a`.
unsafe fn handle<'a>(file: *const PatchvisFile) -> Result<&'a Pvis<'a>, i32> {
    if file.is_null() {
        return Err(PATCHVIS_ERR_ARGUMENT);
    }
    // SAFETY: `file` is non-null and points to a `PatchvisFile` whose `state` `patchvis_parse`
    // wrote (caller contract).
    let state = unsafe { addr_of!((*file).state).read() };
    if state != STATE_PARSED {
        return Err(PATCHVIS_ERR_NOT_PARSED);
    }
    // SAFETY: the marker is written only after a `Pvis` was written to `storage`, which is
    // large and aligned enough (the const assertions above); the bytes it borrows outlive `'a`
    // by the caller's contract.
    Ok(unsafe { &*addr_of!((*file).storage).cast::<Pvis<'a>>() })
}

/// Size of `PatchvisFile` as this library was built: compare with `sizeof(PatchvisFile)` to
/// catch a header that does not match the library.
#[cfg_attr(not(feature = "wasm"), unsafe(no_mangle))]
pub extern "C" fn patchvis_file_size() -> usize {
    size_of::<PatchvisFile>()
}

/// Validates `len` bytes at `data` as a `.pvis` file and, on success, stores the reader in
/// `*out`. Returns 0, a positive file-error code, or `PATCHVIS_ERR_ARGUMENT`. On failure `*out`
/// is marked unparsed, so later calls on it return `PATCHVIS_ERR_NOT_PARSED`.
///
/// # Safety
/// `data` must be valid for reads of `len` bytes (it may be null if `len` is 0), and must stay
/// valid and unmodified for as long as `*out` is used. `out` must be null or point to writable
/// memory of `sizeof(PatchvisFile)` bytes, aligned to 8; it need not be initialised.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn patchvis_parse(
    data: *const u8,
    len: usize,
    out: *mut PatchvisFile,
) -> i32 {
    if out.is_null() {
        return PATCHVIS_ERR_ARGUMENT;
    }
    // SAFETY: `out` is non-null, writable and aligned (caller contract); writing through a raw
    // field pointer reads nothing, so `*out` may be uninitialised.
    unsafe { addr_of_mut!((*out).state).write(0) };
    // SAFETY: caller contract on `data`/`len`, for as long as `*out` is used.
    let Some(bytes) = (unsafe { bytes(data, len) }) else {
        return PATCHVIS_ERR_ARGUMENT;
    };
    match Pvis::parse(bytes) {
        Ok(pvis) => {
            // SAFETY: `storage` is large and aligned enough for a `Pvis` (const assertions);
            // `Pvis` is `Copy`, so overwriting an older one leaks nothing.
            unsafe {
                addr_of_mut!((*out).storage).cast::<Pvis<'_>>().write(pvis);
                addr_of_mut!((*out).state).write(STATE_PARSED);
            }
            PATCHVIS_OK
        }
        Err(error) => file_error_code(&error),
    }
}

/// A static, NUL-terminated description of a return code (never null; unknown codes get
/// "unknown error code").
#[cfg_attr(not(feature = "wasm"), unsafe(no_mangle))]
pub extern "C" fn patchvis_error_message(code: i32) -> *const c_char {
    let message = match code {
        PATCHVIS_OK => c"ok",
        PATCHVIS_ERR_ARGUMENT => c"invalid argument (null pointer or length too large)",
        PATCHVIS_ERR_NOT_PARSED => c"the PatchvisFile was not filled by a successful parse",
        PATCHVIS_ERR_SCRATCH => c"scratch buffer shorter than patchvis_scratch_words",
        PATCHVIS_ERR_RANGE => c"patch or view index out of range, or output buffer too short",
        _ => FILE_ERRORS
            .iter()
            .find(|(c, _)| *c == code)
            .map_or(c"unknown error code", |(_, m)| *m),
    };
    message.as_ptr()
}

/// Writes the reader's precise one-line message for `len` bytes at `data` — the first rule
/// the file breaks, with position and values, exactly as `patchvis verify` prints it, or
/// "ok" — into `buf` (NUL-terminated, cut to `buf_len − 1` bytes). Returns the message's full
/// length, as `snprintf` does; call with `buf_len` 0 to size a buffer. Parses the file again.
///
/// # Safety
/// `data` as for `patchvis_parse` (for the duration of the call only); `buf` must be null with
/// `buf_len` 0, or valid for writes of `buf_len` bytes.
#[cfg_attr(not(feature = "wasm"), unsafe(no_mangle))]
pub unsafe extern "C" fn patchvis_error_detail(
    data: *const u8,
    len: usize,
    buf: *mut c_char,
    buf_len: usize,
) -> usize {
    let mut empty = [];
    let out: &mut [u8] = if buf.is_null() || buf_len == 0 || buf_len > isize::MAX as usize {
        &mut empty
    } else {
        // SAFETY: non-null and valid for `buf_len` bytes of writes (caller contract).
        unsafe { core::slice::from_raw_parts_mut(buf.cast::<u8>(), buf_len) }
    };
    // SAFETY: caller contract on `data`/`len` for this call.
    let message =
        unsafe { bytes(data, len) }.map(|bytes| Pvis::parse(bytes).err().map(|e| e.message()));
    // The reader's own formatter (`runtime::Message`), not `core::fmt`: the WebAssembly
    // reader stays free of `core`'s formatting machinery.
    let text: &[u8] = match &message {
        None => b"invalid argument (null pointer or length too large)",
        Some(None) => b"ok",
        Some(Some(message)) => message.as_bytes(),
    };
    if let Some(room) = out.len().checked_sub(1) {
        let n = text.len().min(room);
        out[..n].copy_from_slice(&text[..n]);
        out[n] = 0;
    }
    text.len()
}

/// The parts of the reader's message for a refused file (`runtime::MessageParts`): the
/// template of its kind of error and the values of the template's holes, for a host that
/// prints the message itself (the WebAssembly module: `npm/patchvis.mjs` fills the
/// templates, so the `.wasm` carries neither the texts nor a number formatter).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PatchvisErrorParts {
    /// Index of the template in `runtime::MESSAGE_TEMPLATES` (the file-error code less 1).
    pub kind: u32,
    /// The values of the template's holes, in order; unused ones are 0.
    pub values: [u64; 6],
}

/// Validates `len` bytes at `data` as `patchvis_parse` does and, if the reader refuses them,
/// writes the parts of its message to `*out` (what `patchvis_error_detail` prints, before
/// formatting). Returns 0 (the file is valid; `*out` is untouched), a positive file-error
/// code, or `PATCHVIS_ERR_ARGUMENT`. Parses the file again.
///
/// # Safety
/// `data` as for `patchvis_parse` (for the duration of the call only); `out` must be null or
/// valid for a write of a `PatchvisErrorParts`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn patchvis_error_parts(
    data: *const u8,
    len: usize,
    out: *mut PatchvisErrorParts,
) -> i32 {
    // SAFETY: caller contract on `data`/`len` for this call.
    let Some(bytes) = (unsafe { bytes(data, len) }) else {
        return PATCHVIS_ERR_ARGUMENT;
    };
    if out.is_null() {
        return PATCHVIS_ERR_ARGUMENT;
    }
    let Err(error) = Pvis::parse(bytes) else {
        return PATCHVIS_OK;
    };
    let parts = error.parts();
    // SAFETY: `out` is non-null and valid for a write (caller contract).
    unsafe {
        out.write(PatchvisErrorParts {
            kind: parts.kind,
            values: parts.values,
        })
    };
    file_error_code(&error)
}

/// Fills `*out` with what the file holds. Returns 0, `PATCHVIS_ERR_ARGUMENT` or
/// `PATCHVIS_ERR_NOT_PARSED`.
///
/// # Safety
/// `file` as for every call: null, or a `PatchvisFile` passed to `patchvis_parse` whose bytes
/// are still valid. `out` must be null or valid for a write of a `PatchvisInfo`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn patchvis_info(file: *const PatchvisFile, out: *mut PatchvisInfo) -> i32 {
    // SAFETY: caller contract on `file`.
    let pvis = match unsafe { handle(file) } {
        Ok(pvis) => pvis,
        Err(code) => return code,
    };
    if out.is_null() {
        return PATCHVIS_ERR_ARGUMENT;
    }
    let s = pvis.sampling();
    let info = PatchvisInfo {
        version: pvis.version(),
        patch_count: pvis.patch_count(),
        triangle_count: pvis.triangle_count(),
        level: s.level,
        views: s.views,
        center: s.center,
        radius: s.radius,
        distance: s.distance,
        fov_deg: s.fov_deg,
        resolution: s.resolution,
        total_bytes: pvis.total_bytes(),
        scratch_words: pvis.scratch_words(),
    };
    // SAFETY: `out` is non-null and valid for a write (caller contract).
    unsafe { out.write(info) };
    PATCHVIS_OK
}

/// One sampling shell of a file (spec § SHEL; `runtime::Shell`). Shells `0..=K` are numbered
/// by decreasing distance: the sampling sphere is shell `J` (`patchvis_sampling_shell`), the
/// SHEL records the others, those beyond the sampling distance first.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PatchvisShell {
    /// Camera distance from the centre.
    pub distance: f32,
    /// Sphere subdivision level of the shell's views.
    pub level: u32,
    /// Number of views, `4·4^level + 2`.
    pub views: u32,
    /// The VISB encoding of the shell's rows.
    pub encoding: u32,
    /// Bytes of the shell's rows.
    pub bytes: u64,
}

/// `K`, the file's sampling shells besides the sampling sphere (0 without SHEL); 0 for a null
/// or unparsed `file`.
///
/// # Safety
/// `file` as for every call.
#[cfg_attr(not(feature = "wasm"), unsafe(no_mangle))]
pub unsafe extern "C" fn patchvis_shell_count(file: *const PatchvisFile) -> u32 {
    // SAFETY: caller contract on `file`.
    unsafe { handle(file) }.map_or(0, |pvis| pvis.shell_count())
}

/// `J`, the shell number of the sampling sphere: how many SHEL records lie beyond the sampling
/// distance (version 6's far band); 0 for a file without them, a null or an unparsed `file`.
///
/// # Safety
/// `file` as for every call.
#[cfg_attr(not(feature = "wasm"), unsafe(no_mangle))]
pub unsafe extern "C" fn patchvis_sampling_shell(file: *const PatchvisFile) -> u32 {
    // SAFETY: caller contract on `file`.
    unsafe { handle(file) }.map_or(0, |pvis| pvis.sampling_shell())
}

/// SHEL's reach: how far from the centre an eye between the sampling sphere and the first far
/// shell is answered by the sampling sphere alone (spec § SHEL); 0 where the file has none, and
/// for a null or an unparsed `file`.
///
/// # Safety
/// `file` as for every call.
#[cfg_attr(not(feature = "wasm"), unsafe(no_mangle))]
pub unsafe extern "C" fn patchvis_sampling_reach(file: *const PatchvisFile) -> f32 {
    // SAFETY: caller contract on `file`.
    unsafe { handle(file) }.map_or(0.0, |pvis| pvis.sampling_reach())
}

/// Describes shell `s` (`0..=K`, outermost first; `J` is the sampling sphere) in `*out`.
/// Returns 0, `PATCHVIS_ERR_ARGUMENT` (`out` null), `PATCHVIS_ERR_NOT_PARSED` or
/// `PATCHVIS_ERR_RANGE` (`s > K`).
///
/// # Safety
/// `file` as for every call; `out` null or valid for a write of a `PatchvisShell`.
#[cfg_attr(not(feature = "wasm"), unsafe(no_mangle))]
pub unsafe extern "C" fn patchvis_shell(
    file: *const PatchvisFile,
    s: u32,
    out: *mut PatchvisShell,
) -> i32 {
    // SAFETY: caller contract on `file`.
    let pvis = match unsafe { handle(file) } {
        Ok(pvis) => pvis,
        Err(code) => return code,
    };
    if out.is_null() {
        return PATCHVIS_ERR_ARGUMENT;
    }
    if s > pvis.shell_count() {
        return PATCHVIS_ERR_RANGE;
    }
    let shell = pvis.shell(s);
    let info = PatchvisShell {
        distance: shell.distance,
        level: shell.level,
        views: shell.views,
        encoding: shell.encoding,
        bytes: shell.bytes,
    };
    // SAFETY: `out` is non-null and valid for a write (caller contract).
    unsafe { out.write(info) };
    PATCHVIS_OK
}

/// `u64` words of scratch `patchvis_query` needs, `ceil(patch_count / 64)`; 0 for a null or
/// unparsed `file`.
///
/// # Safety
/// `file` as for every call.
#[cfg_attr(not(feature = "wasm"), unsafe(no_mangle))]
pub unsafe extern "C" fn patchvis_scratch_words(file: *const PatchvisFile) -> usize {
    // SAFETY: caller contract on `file`.
    unsafe { handle(file) }.map_or(0, |pvis| pvis.scratch_words())
}

/// The patches visible from `eye` (model space; spec § Query), computed into `scratch` and
/// described by `*out`. Non-finite eyes get every patch with `inside_sphere` 1. Returns 0,
/// `PATCHVIS_ERR_ARGUMENT`, `PATCHVIS_ERR_NOT_PARSED` or `PATCHVIS_ERR_SCRATCH`.
///
/// # Safety
/// `file` as for every call. `eye` must be null or point to 3 readable floats. `scratch` must
/// be null or valid for reads and writes of `scratch_words` `uint64_t`s, and must not overlap
/// the file's bytes; the answer stays valid until `scratch` is reused. `out` must be null or
/// valid for a write of a `PatchvisVisible`.
#[cfg_attr(not(feature = "wasm"), unsafe(no_mangle))]
pub unsafe extern "C" fn patchvis_query(
    file: *const PatchvisFile,
    eye: *const f32,
    scratch: *mut u64,
    scratch_words: usize,
    out: *mut PatchvisVisible,
) -> i32 {
    // SAFETY: caller contract on `file`.
    let pvis = match unsafe { handle(file) } {
        Ok(pvis) => pvis,
        Err(code) => return code,
    };
    if eye.is_null() || scratch.is_null() || out.is_null() {
        return PATCHVIS_ERR_ARGUMENT;
    }
    if scratch_words > isize::MAX as usize / size_of::<u64>() {
        return PATCHVIS_ERR_ARGUMENT;
    }
    if scratch_words < pvis.scratch_words() {
        return PATCHVIS_ERR_SCRATCH;
    }
    // SAFETY: `eye` is non-null and points to 3 readable floats (caller contract).
    let eye = unsafe { [eye.read(), eye.add(1).read(), eye.add(2).read()] };
    // SAFETY: non-null, valid for `scratch_words` words of reads and writes, not overlapping
    // the file (caller contract); the length fits a slice (checked above).
    let scratch = unsafe { core::slice::from_raw_parts_mut(scratch, scratch_words) };
    let visible = pvis.query(eye, scratch);
    // SAFETY: `out` is non-null and valid for a write (caller contract).
    unsafe { out.write(PatchvisVisible::of(&visible)) };
    PATCHVIS_OK
}

/// The triangle range of `patch`: `*first` and `*count`. Returns 0, `PATCHVIS_ERR_ARGUMENT`,
/// `PATCHVIS_ERR_NOT_PARSED` or `PATCHVIS_ERR_RANGE` (patch ≥ patch_count).
///
/// # Safety
/// `file` as for every call; `first` and `count` must be null or valid for a write.
#[cfg_attr(not(feature = "wasm"), unsafe(no_mangle))]
pub unsafe extern "C" fn patchvis_patch_range(
    file: *const PatchvisFile,
    patch: u32,
    first: *mut u32,
    count: *mut u32,
) -> i32 {
    // SAFETY: caller contract on `file`.
    let pvis = match unsafe { handle(file) } {
        Ok(pvis) => pvis,
        Err(code) => return code,
    };
    if first.is_null() || count.is_null() {
        return PATCHVIS_ERR_ARGUMENT;
    }
    if patch >= pvis.patch_count() {
        return PATCHVIS_ERR_RANGE;
    }
    let info = pvis.patch(patch);
    // SAFETY: both non-null and valid for a write (caller contract).
    unsafe {
        first.write(info.first_triangle);
        count.write(info.triangle_count);
    }
    PATCHVIS_OK
}

/// The merged triangle ranges of the visible set `visible` (an answer of `patchvis_query` or
/// `patchvis_stream_query` on this file): `out[2·i]` and `out[2·i + 1]` are the first triangle
/// and the count of range `i`, ascending, adjacent ranges merged, `*ranges` of them. Returns
/// 0, `PATCHVIS_ERR_ARGUMENT`, `PATCHVIS_ERR_NOT_PARSED` or `PATCHVIS_ERR_RANGE` (more ranges
/// than `capacity`: `*ranges` is then the number needed, and `out` holds the first
/// `capacity`). `capacity = ceil(patch_count / 2)` always suffices. One call instead of one
/// `patchvis_patch_range` a patch: ranges of a compact table are found walking the patches.
///
/// # Safety
/// `file` as for every call; `visible` null or valid for a read, its `bits` valid for
/// `words` words of reads (as an answer leaves them); `out` null or valid for `2·capacity`
/// writes; `ranges` null or valid for a write.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn patchvis_ranges(
    file: *const PatchvisFile,
    visible: *const PatchvisVisible,
    out: *mut u32,
    capacity: usize,
    ranges: *mut usize,
) -> i32 {
    // SAFETY: caller contract on `file`.
    let pvis = match unsafe { handle(file) } {
        Ok(pvis) => pvis,
        Err(code) => return code,
    };
    if visible.is_null() || ranges.is_null() || (out.is_null() && capacity > 0) {
        return PATCHVIS_ERR_ARGUMENT;
    }
    // SAFETY: non-null and valid for a read (caller contract).
    let visible = unsafe { visible.read() };
    if visible.bits.is_null() || visible.words != pvis.row_words() {
        return PATCHVIS_ERR_ARGUMENT;
    }
    // SAFETY: an answer's bits, valid for `words` reads (caller contract).
    let bits = unsafe { core::slice::from_raw_parts(visible.bits, visible.words) };
    let mut n = 0usize;
    for (first, count) in crate::runtime::ranges_of_bits(pvis, bits) {
        if n < capacity {
            // SAFETY: `out` is valid for `2·capacity` writes and `n < capacity`.
            unsafe {
                out.add(2 * n).write(first);
                out.add(2 * n + 1).write(count);
            }
        }
        n += 1;
    }
    // SAFETY: non-null and valid for a write (caller contract).
    unsafe { ranges.write(n) };
    if n > capacity {
        PATCHVIS_ERR_RANGE
    } else {
        PATCHVIS_OK
    }
}

/// Decodes the row of `view` into `out[0 .. ceil(patch_count / 64)]` (same bit layout as a
/// query's answer). Returns 0, `PATCHVIS_ERR_ARGUMENT`, `PATCHVIS_ERR_NOT_PARSED` or
/// `PATCHVIS_ERR_RANGE` (view ≥ views, or `words` < `patchvis_scratch_words`).
///
/// # Safety
/// `file` as for every call; `out` must be null or valid for writes of `words` `uint64_t`s.
#[cfg_attr(not(feature = "wasm"), unsafe(no_mangle))]
pub unsafe extern "C" fn patchvis_view_row(
    file: *const PatchvisFile,
    view: u32,
    out: *mut u64,
    words: usize,
) -> i32 {
    // SAFETY: caller contract on `file`.
    let pvis = match unsafe { handle(file) } {
        Ok(pvis) => pvis,
        Err(code) => return code,
    };
    if out.is_null() || words > isize::MAX as usize / size_of::<u64>() {
        return PATCHVIS_ERR_ARGUMENT;
    }
    if view >= pvis.sampling().views || words < pvis.row_words() {
        return PATCHVIS_ERR_RANGE;
    }
    // SAFETY: non-null and valid for `words` words of writes (caller contract).
    let out = unsafe { core::slice::from_raw_parts_mut(out, words) };
    pvis.view_row(view, out);
    PATCHVIS_OK
}

/// A streaming query state (`runtime::Streaming`), in memory the caller provides. Opaque.
#[repr(C)]
pub struct PatchvisStream {
    /// [`STATE_STREAMING`] once `patchvis_stream_init` succeeded, 0 after it failed.
    state: u64,
    /// Holds a `Streaming` when `state` says so.
    storage: [MaybeUninit<u64>; STREAM_WORDS],
}

/// Size of `PatchvisStream` as this library was built.
#[cfg_attr(not(feature = "wasm"), unsafe(no_mangle))]
pub extern "C" fn patchvis_stream_size() -> usize {
    size_of::<PatchvisStream>()
}

/// `u64` words of scratch a streaming state needs (`Pvis::scratch_bound`: the decoded rows of
/// its path, plus 32 KiB of tree-walk memo for VISB encoding 2); 0 for a null or unparsed
/// `file`.
///
/// # Safety
/// `file` as for every call.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn patchvis_stream_scratch_words(file: *const PatchvisFile) -> usize {
    // SAFETY: caller contract on `file`.
    unsafe { handle(file) }.map_or(0, |pvis| pvis.scratch_bound())
}

/// Starts a streaming query state over `file` in `*out`, keeping its decoded rows in
/// `scratch`. Returns 0, `PATCHVIS_ERR_ARGUMENT`, `PATCHVIS_ERR_NOT_PARSED` or
/// `PATCHVIS_ERR_SCRATCH` (fewer than `patchvis_stream_scratch_words` words). On failure
/// `*out` is marked unusable.
///
/// # Safety
/// `file` as for every call, and its bytes must stay valid while `*out` is used (the state
/// holds its own copy of the reader, so `*file` itself may go). `scratch` must be valid for
/// reads and writes of `scratch_words` words for as long as `*out` is used, used by nothing
/// else meanwhile, and not overlap the file's bytes. `out` must be null or point to writable
/// memory of `sizeof(PatchvisStream)` bytes, aligned to 8.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn patchvis_stream_init(
    file: *const PatchvisFile,
    scratch: *mut u64,
    scratch_words: usize,
    out: *mut PatchvisStream,
) -> i32 {
    if out.is_null() {
        return PATCHVIS_ERR_ARGUMENT;
    }
    // SAFETY: `out` is non-null, writable and aligned (caller contract).
    unsafe { addr_of_mut!((*out).state).write(0) };
    // SAFETY: caller contract on `file`; its bytes outlive `*out`.
    let pvis: Pvis<'static> = match unsafe { handle(file) } {
        Ok(pvis) => *pvis,
        Err(code) => return code,
    };
    if scratch.is_null() || scratch_words > isize::MAX as usize / size_of::<u64>() {
        return PATCHVIS_ERR_ARGUMENT;
    }
    if scratch_words < pvis.scratch_bound() {
        return PATCHVIS_ERR_SCRATCH;
    }
    // SAFETY: non-null, valid for reads and writes of `scratch_words` words for as long as
    // `*out` is used, and used by nothing else (caller contract).
    let scratch: &'static mut [u64] =
        unsafe { core::slice::from_raw_parts_mut(scratch, scratch_words) };
    let stream = pvis.streaming(scratch);
    // SAFETY: `storage` is large and aligned enough for a `Streaming` (const assertions); a
    // `Streaming` owns no resources, so overwriting an older one leaks nothing.
    unsafe {
        addr_of_mut!((*out).storage)
            .cast::<Streaming<'static, 'static>>()
            .write(stream);
        addr_of_mut!((*out).state).write(STATE_STREAMING);
    }
    PATCHVIS_OK
}

/// The patches visible from `eye`, as `patchvis_query` answers, from the streaming state: a
/// camera that stays in its leaf costs only the point location, a move to a neighbouring leaf
/// decodes the few rows it needs. The answer lives in the state's scratch until the next
/// query on it. Returns 0, `PATCHVIS_ERR_ARGUMENT` or `PATCHVIS_ERR_NOT_PARSED` (not from a
/// successful `patchvis_stream_init`).
///
/// # Safety
/// `stream` must be null or a `PatchvisStream` passed to `patchvis_stream_init`, whose file
/// bytes and scratch are still valid, not used by another thread at the same time. `eye` must
/// be null or point to 3 readable floats; `out` null or valid for a write of a
/// `PatchvisVisible`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn patchvis_stream_query(
    stream: *mut PatchvisStream,
    eye: *const f32,
    out: *mut PatchvisVisible,
) -> i32 {
    if stream.is_null() || eye.is_null() || out.is_null() {
        return PATCHVIS_ERR_ARGUMENT;
    }
    // SAFETY: non-null and points to a `PatchvisStream` (caller contract).
    if unsafe { addr_of!((*stream).state).read() } != STATE_STREAMING {
        return PATCHVIS_ERR_NOT_PARSED;
    }
    // SAFETY: the marker is written only after a `Streaming` was written to `storage`; its
    // borrows are valid and exclusive for now (caller contract).
    let state =
        unsafe { &mut *addr_of_mut!((*stream).storage).cast::<Streaming<'static, 'static>>() };
    // SAFETY: `eye` is non-null and points to 3 readable floats (caller contract).
    let eye = unsafe { [eye.read(), eye.add(1).read(), eye.add(2).read()] };
    let visible = state.query(eye);
    // SAFETY: `out` is non-null and valid for a write (caller contract).
    unsafe { out.write(PatchvisVisible::of(&visible)) };
    PATCHVIS_OK
}

/// A view frustum (spec § Frustum culling) as six planes `[a, b, c, d]`, each keeping the
/// points with `a·x + b·y + c·z + d ≥ 0` (model space). Filled by
/// [`patchvis_frustum_from_view_proj`] or by the caller; any values are safe (NaN and
/// infinities keep every patch).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PatchvisFrustum {
    /// Left, right, bottom, top, near, far (any order works).
    pub planes: [[f32; 4]; 6],
}

impl PatchvisFrustum {
    fn frustum(&self) -> Frustum {
        Frustum::from_planes(self.planes)
    }
}

/// `depth` of [`patchvis_frustum_from_view_proj`]: clip `−w ≤ z ≤ w` (OpenGL, WebGL).
pub const PATCHVIS_DEPTH_NEGATIVE_ONE_TO_ONE: i32 = 0;
/// `depth` of [`patchvis_frustum_from_view_proj`]: clip `0 ≤ z ≤ w` (Direct3D, Vulkan, Metal,
/// wgpu).
pub const PATCHVIS_DEPTH_ZERO_TO_ONE: i32 = 1;

/// Fills `*out` with the frustum of the column-major view-projection matrix `m` (16 floats,
/// `m[4·col + row]`, model space to clip space) whose clip depth range is `depth`
/// (`PATCHVIS_DEPTH_NEGATIVE_ONE_TO_ONE` or `PATCHVIS_DEPTH_ZERO_TO_ONE`). Returns 0 or
/// `PATCHVIS_ERR_ARGUMENT` (a null pointer or another `depth`).
///
/// # Safety
/// `m` must be null or point to 16 readable floats; `out` null or valid for a write.
// Not exported to WebAssembly: `npm/patchvis.mjs` does not call it.
#[cfg_attr(not(feature = "wasm"), unsafe(no_mangle))]
pub unsafe extern "C" fn patchvis_frustum_from_view_proj(
    m: *const f32,
    depth: i32,
    out: *mut PatchvisFrustum,
) -> i32 {
    if m.is_null() || out.is_null() {
        return PATCHVIS_ERR_ARGUMENT;
    }
    let depth = match depth {
        PATCHVIS_DEPTH_NEGATIVE_ONE_TO_ONE => DepthRange::NegativeOneToOne,
        PATCHVIS_DEPTH_ZERO_TO_ONE => DepthRange::ZeroToOne,
        _ => return PATCHVIS_ERR_ARGUMENT,
    };
    // SAFETY: `m` is non-null and points to 16 readable floats (caller contract).
    let matrix: [f32; 16] = core::array::from_fn(|i| unsafe { m.add(i).read() });
    let planes = Frustum::from_view_projection(&matrix, depth).planes();
    // SAFETY: `out` is non-null and valid for a write (caller contract).
    unsafe { out.write(PatchvisFrustum { planes }) };
    PATCHVIS_OK
}

/// As [`patchvis_query`], without the patches whose bounding spheres lie wholly outside
/// `*frustum` (spec § Frustum culling): the set to draw, in `scratch`. Returns the same codes
/// as `patchvis_query`, and `PATCHVIS_ERR_ARGUMENT` for a null `frustum`.
///
/// # Safety
/// As for [`patchvis_query`]; `frustum` must be null or point to a readable
/// `PatchvisFrustum`.
// Not exported to WebAssembly: `npm/patchvis.mjs` does not call it.
#[cfg_attr(not(feature = "wasm"), unsafe(no_mangle))]
pub unsafe extern "C" fn patchvis_query_frustum(
    file: *const PatchvisFile,
    eye: *const f32,
    frustum: *const PatchvisFrustum,
    scratch: *mut u64,
    scratch_words: usize,
    out: *mut PatchvisVisible,
) -> i32 {
    // SAFETY: caller contract on `file`.
    let pvis = match unsafe { handle(file) } {
        Ok(pvis) => pvis,
        Err(code) => return code,
    };
    if eye.is_null() || frustum.is_null() || scratch.is_null() || out.is_null() {
        return PATCHVIS_ERR_ARGUMENT;
    }
    if scratch_words > isize::MAX as usize / size_of::<u64>() {
        return PATCHVIS_ERR_ARGUMENT;
    }
    if scratch_words < pvis.scratch_words() {
        return PATCHVIS_ERR_SCRATCH;
    }
    // SAFETY: `frustum` is non-null and readable (caller contract).
    let frustum = unsafe { frustum.read() }.frustum();
    // SAFETY: `eye` is non-null and points to 3 readable floats (caller contract).
    let eye = unsafe { [eye.read(), eye.add(1).read(), eye.add(2).read()] };
    // SAFETY: non-null, valid for `scratch_words` words of reads and writes, not overlapping
    // the file (caller contract); the length fits a slice (checked above).
    let scratch = unsafe { core::slice::from_raw_parts_mut(scratch, scratch_words) };
    let visible = pvis.query_in_frustum(eye, &frustum, scratch);
    // SAFETY: `out` is non-null and valid for a write (caller contract).
    unsafe { out.write(PatchvisVisible::of(&visible)) };
    PATCHVIS_OK
}

/// As [`patchvis_stream_query`], without the patches whose bounding spheres lie wholly outside
/// `*frustum`; the answer is written to `bits` (at least `patchvis_scratch_words(file)` words,
/// not the state's scratch), which `out->bits` then points to. Returns 0,
/// `PATCHVIS_ERR_ARGUMENT`, `PATCHVIS_ERR_NOT_PARSED` or `PATCHVIS_ERR_RANGE` (`words` too
/// small for a row).
///
/// # Safety
/// As for [`patchvis_stream_query`]; `frustum` must be null or point to a readable
/// `PatchvisFrustum`; `bits` null or valid for reads and writes of `words` words, overlapping
/// neither the state's scratch nor the file's bytes.
// Not exported to WebAssembly: `npm/patchvis.mjs` does not call it.
#[cfg_attr(not(feature = "wasm"), unsafe(no_mangle))]
pub unsafe extern "C" fn patchvis_stream_query_frustum(
    stream: *mut PatchvisStream,
    eye: *const f32,
    frustum: *const PatchvisFrustum,
    bits: *mut u64,
    words: usize,
    out: *mut PatchvisVisible,
) -> i32 {
    if stream.is_null() || eye.is_null() || frustum.is_null() || bits.is_null() || out.is_null() {
        return PATCHVIS_ERR_ARGUMENT;
    }
    if words > isize::MAX as usize / size_of::<u64>() {
        return PATCHVIS_ERR_ARGUMENT;
    }
    // SAFETY: non-null and points to a `PatchvisStream` (caller contract).
    if unsafe { addr_of!((*stream).state).read() } != STATE_STREAMING {
        return PATCHVIS_ERR_NOT_PARSED;
    }
    // SAFETY: the marker is written only after a `Streaming` was written to `storage`; its
    // borrows are valid and exclusive for now (caller contract).
    let state =
        unsafe { &mut *addr_of_mut!((*stream).storage).cast::<Streaming<'static, 'static>>() };
    if words < state.row_words() {
        return PATCHVIS_ERR_RANGE;
    }
    // SAFETY: `frustum` is non-null and readable (caller contract).
    let frustum = unsafe { frustum.read() }.frustum();
    // SAFETY: `eye` is non-null and points to 3 readable floats (caller contract).
    let eye = unsafe { [eye.read(), eye.add(1).read(), eye.add(2).read()] };
    // SAFETY: non-null, valid for `words` words of reads and writes, overlapping nothing the
    // state uses (caller contract); the length fits a slice (checked above).
    let bits = unsafe { core::slice::from_raw_parts_mut(bits, words) };
    let visible = state.query_in_frustum(eye, &frustum, bits);
    // SAFETY: `out` is non-null and valid for a write (caller contract).
    unsafe { out.write(PatchvisVisible::of(&visible)) };
    PATCHVIS_OK
}

#[cfg(test)]
mod tests;
