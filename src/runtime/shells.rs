//! The sampling shells of a version-5 or -6 file (spec § SHEL) and the band rule of § Query:
//! which shells' rows answer an eye nearer or farther than the sampling sphere.
//!
//! The file's shells, numbered `0..=K` by decreasing distance, are SHEL's `K` records with the
//! sampling sphere itself (CAMR, VISB) among them: the `J` records beyond the sampling
//! distance (version 6, the far band) are shells `0..J`, the sampling sphere is shell `J`,
//! and the records nearer the model are shells `J + 1..=K` (without outer records `J = 0`, as
//! in version 5). An eye's *band* is the number of shells it is strictly inside (`|d|² <
//! D_s²`, exact as in § Query step 3); band `b` answers with the OR of the leaf rows of
//! shells `b − 1` and `b` (one shell at either end), except that an eye of band `J` inside
//! SHEL's `reach` is answered by the sampling sphere alone (its probe cells hold every camera
//! out to there, so the next shell out would only cost culling). A shell's payload is a VISB
//! body; a `Pvis` keeps only where SHEL is, so it stays a few words however many shells it has,
//! and a shell's rows are opened again when they are needed (`Pvis::visb_of`) by `Visb::at`,
//! the one reading of a checked VISB body, which parse uses too, for VISB and for each payload
//! it checks (the embedded readers carry one VISB reader, not two). Cost: `band` is at most
//! `K + 2` exact comparisons (one more for SHEL's reach), almost all settled in binary32;
//! opening a payload reads its fixed fields and, for a tree, its nodes (at most 1,024), not its
//! records, which the stateless query pays per shell and the streaming and expanded modes once
//! per shell they move to.
//!
//! Without feature `shells` the reader is a far-only reader (spec § SHEL, far-only readers):
//! parse skips SHEL's contents and `K` reads as the constant 0, so the compiler drops the shell
//! paths of every query mode (2.9 KB of flash on a Cortex-M4F, 1.0 KB gzipped of WebAssembly).

use super::consts::*;
use super::exact::norm_below;
use super::fields::Section;

/// The SHEL section of a validated file: its body (empty without shells), where it starts
/// in the file, and `K`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Shells<'a> {
    body: &'a [u8],
    offset: u64,
    count: u32,
    /// `J`: the records beyond the sampling distance, which come first (shell `J` is the
    /// sampling sphere).
    pub(crate) sampling_at: u32,
    /// SHEL's `reach` (0: none): an eye of band `J` nearer than it is answered by the
    /// sampling sphere alone.
    pub(crate) reach: f32,
    /// The finest level of the SHEL records (0 without shells).
    pub(crate) max_level: u32,
    /// Whether a shell's payload uses VISB encoding 2 (a tree, whose lookups the streaming
    /// state memoises).
    pub(crate) tree: bool,
}

impl<'a> Shells<'a> {
    /// No shells: a file of version ≤ 4, or one without SHEL.
    pub(crate) const NONE: Shells<'static> = Shells {
        body: &[],
        offset: 0,
        count: 0,
        sampling_at: 0,
        reach: 0.0,
        max_level: 0,
        tree: false,
    };

    /// The shells of a SHEL `body` at `offset` in the file, whose records parse checked (or is
    /// checking).
    pub(crate) fn new(body: &'a [u8], offset: u64, count: u32) -> Self {
        Shells {
            body,
            offset,
            count,
            sampling_at: 0,
            reach: 0.0,
            max_level: 0,
            tree: false,
        }
    }

    /// `J`: the shell number of the sampling sphere (the records beyond it, version 6's far
    /// band). 0 in a far-only reader.
    pub(crate) fn sampling(&self) -> u32 {
        if cfg!(feature = "shells") {
            self.sampling_at
        } else {
            0
        }
    }

    /// The record (`1..=K`) of shell `s` (`0..=K`, not the sampling sphere's `J`).
    pub(crate) fn record(&self, s: u32) -> u32 {
        if s < self.sampling() { s + 1 } else { s }
    }

    /// Camera distance of shell `s` (`0..=K`): its record's, or `outer` (CAMR's) for the
    /// sampling sphere.
    pub(crate) fn shell_distance(&self, s: u32, outer: f32) -> f32 {
        if s == self.sampling() {
            outer
        } else {
            self.distance(self.record(s))
        }
    }

    /// `K`: the shells besides the sampling sphere. Always 0 in a far-only reader (without
    /// feature `shells`, spec § SHEL, far-only readers), which answers as if SHEL were absent: the
    /// constant lets the compiler drop every shell path.
    pub(crate) fn count(&self) -> u32 {
        if cfg!(feature = "shells") {
            self.count
        } else {
            0
        }
    }

    /// Length of the SHEL section (0 without one).
    pub(crate) fn section_bytes(&self) -> u64 {
        self.body.len() as u64
    }

    /// A `u32` of the record of shell `k` (`1..=K`) at `field` bytes into it.
    fn field(&self, k: u32, field: usize) -> u32 {
        let at = (SHEL_HEADER_LEN + SHELL_RECORD_LEN * u64::from(k.saturating_sub(1))) as usize;
        self.body
            .get(at + field..at + field + 4)
            .map_or(0, |b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    }

    /// Camera distance of record `k` (`1..=K`).
    pub(crate) fn distance(&self, k: u32) -> f32 {
        f32::from_bits(self.field(k, 0))
    }

    /// Sphere level of record `k` (`1..=K`).
    pub(crate) fn level(&self, k: u32) -> u32 {
        self.field(k, 4)
    }

    /// The stored payload length of record `k` (`1..=K`).
    pub(crate) fn payload_length(&self, k: u32) -> u64 {
        u64::from(self.field(k, 8)) | u64::from(self.field(k, 12)) << 32
    }

    /// Where record `k`'s payload lies in the file: a VISB body, as parse checked it. Payloads
    /// follow the records in record order, contiguous.
    pub(crate) fn payload(&self, k: u32) -> Section {
        let mut offset = self.offset + SHEL_HEADER_LEN + SHELL_RECORD_LEN * u64::from(self.count);
        let mut length = 0;
        for j in 1..k + 1 {
            offset = offset.saturating_add(length);
            length = self.payload_length(j);
        }
        Section { offset, length }
    }
}

/// An eye's band (§ Query step 3) and the shells that answer it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Band {
    /// How many of the shells `0..=K` the eye is strictly inside.
    pub(crate) band: u32,
    /// The outer answering shell: `band − 1` (0 for band 0), or `J` for an eye of band `J`
    /// inside SHEL's `reach`, which the sampling sphere alone answers.
    pub(crate) outer: u32,
}

impl Band {
    /// The answering shells `[outer, inner]` in a file with `k` shells, equal where one shell
    /// answers (band 0: the sampling sphere; band `K + 1`: shell `K`; an eye within the
    /// reach: the sampling sphere).
    pub(crate) fn shells(self, k: u32) -> [u32; 2] {
        [self.outer, self.band.min(k)]
    }

    /// Band `K + 1` of a file with `k` shells: inside the innermost, which alone answers.
    pub(crate) fn innermost(k: u32) -> Band {
        Band {
            band: k + 1,
            outer: k,
        }
    }
}

/// The band of an eye at offset `d` from the centre (§ Query): how many of the shells
/// `0..=K` it is strictly inside, `outer` being CAMR's distance (the sampling sphere's).
/// Distances decrease, so the count stops at the first shell the eye is not inside.
pub(crate) fn band(d: [f32; 3], outer: f32, shells: &Shells<'_>) -> Band {
    let mut b = 0;
    while b <= shells.count() && norm_below(d, shells.shell_distance(b, outer)) {
        b += 1;
    }
    // Within the reach, band `J`'s eye is answered by the sampling sphere alone (a reach of 0
    // holds no eye).
    let j = shells.sampling();
    let alone = b == j && b > 0 && norm_below(d, shells.reach);
    Band {
        band: b,
        outer: if alone { j } else { b.saturating_sub(1) },
    }
}
