//! Queries against a validated file (spec § Query): the visible set of an eye position, and
//! iterators over its patches and their merged triangle ranges.
//!
//! Cost: the eye's band (§ Query: which shells it is inside, `shells.rs`), one
//! `sphere::locate` (≤ 4 plane tests per level) on each of the one or two shells that answer,
//! and three rows a shell OR-ed into the caller's scratch; iteration is one `trailing_zeros`
//! per visible patch. No allocation.

use super::Pvis;
use super::shells::Band;
use crate::sphere;

/// The answer to a query: which patches are visible, and which shells' views answered (spec
/// § Query). Borrows the caller's scratch space.
///
/// The file's shells `0..=K` ([`super::Pvis::shell_count`]) are numbered by decreasing
/// distance, the sampling sphere among them at [`super::Pvis::sampling_shell`] (0 without a
/// far band). The eye's [`band`](Self::band) says which it is inside, and so which one or two
/// shells' rows were combined:
///
/// | `band`       | where the eye is                          | `shells`         | `inside_sphere` |
/// |--------------|-------------------------------------------|------------------|-----------------|
/// | 0            | at or beyond the outermost shell          | `[0, 0]`         | false           |
/// | `1..=K`      | inside shell `band − 1`, not inside `band`| `[band − 1, band]` | false         |
/// | `K + 1`      | inside the innermost shell (shell `K`)    | `[K, K]`         | true            |
///
/// An eye of band `J` (between the sampling sphere and the first far shell) nearer than SHEL's
/// reach ([`super::Pvis::sampling_reach`]) is answered by the sampling sphere alone: `[J, J]`.
///
/// A file without shells (`K = 0`, every version-1–4 file) has bands 0 and 1, as before: inside
/// the sampling sphere is `inside_sphere`. An eye with a non-finite offset gets every patch,
/// band `K + 1`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Visible<'s> {
    /// Whether the eye is inside the innermost shell (the sampling sphere for a file without
    /// shells), where no sampled view is nearer: the answer is then only an approximation, and
    /// callers may prefer to draw everything.
    pub inside_sphere: bool,
    /// How many of the shells `0..=K` the eye is strictly inside: `0..=K + 1`. See the table
    /// above.
    pub band: u32,
    /// The shells whose rows were combined, outer first: `[band − 1, band]` between two
    /// shells, the same shell twice where only one answered (band 0, band `K + 1`, and band
    /// `J` inside SHEL's reach: `[J, J]`).
    pub shells: [u32; 2],
    /// The three views of shell `shells[0]` whose rows were combined (the corners of that
    /// shell's face under the eye).
    pub leaf: [u32; 3],
    /// The three views of shell `shells[1]` whose rows were combined; equal to `leaf` where
    /// one shell answered.
    pub inner_leaf: [u32; 3],
    bits: &'s [u64],
    patch_count: u32,
}

impl<'s> Visible<'s> {
    /// Whether patch `p` is visible (false for `p` past the last patch).
    pub fn contains(&self, p: u32) -> bool {
        p < self.patch_count
            && self
                .bits
                .get(p as usize / 64)
                .is_some_and(|w| w >> (p % 64) & 1 == 1)
    }

    /// The visible patches, ascending.
    pub fn patches(&self) -> Patches<'s> {
        Patches::of_bits(self.bits)
    }

    /// Number of visible patches.
    pub fn count(&self) -> u32 {
        self.bits.iter().map(|w| w.count_ones()).sum()
    }

    /// The visible set as bits: bit `p % 64` of word `p / 64` is patch `p`; bits past the last
    /// patch are zero.
    pub fn bits(&self) -> &[u64] {
        self.bits
    }

    /// Where the answer came from, to wrap other bits (a frustum's cut) with it.
    pub(super) fn place(&self) -> Place {
        Place {
            band: Band {
                band: self.band,
                outer: self.shells[0],
            },
            leaves: [self.leaf, self.inner_leaf],
        }
    }
}

/// Iterator over the visible patches, ascending. See [`Visible::patches`].
#[derive(Clone, Debug)]
pub struct Patches<'s> {
    bits: &'s [u64],
    word: usize,
    current: u64,
}

impl<'s> Patches<'s> {
    /// The set bits of any row in the reader's layout (bit `p % 64` of word `p / 64` is patch
    /// `p`), ascending: one `trailing_zeros` per set bit.
    pub fn of_bits(bits: &'s [u64]) -> Patches<'s> {
        Patches {
            bits,
            word: 0,
            current: bits.first().copied().unwrap_or(0),
        }
    }
}

impl Iterator for Patches<'_> {
    type Item = u32;

    fn next(&mut self) -> Option<u32> {
        while self.current == 0 {
            self.word += 1;
            self.current = *self.bits.get(self.word)?;
        }
        let bit = self.current.trailing_zeros();
        self.current &= self.current - 1;
        Some(self.word as u32 * 64 + bit)
    }
}

/// Iterator over `(first_triangle, triangle_count)` of the visible patches, with ranges of
/// consecutive patches merged (they are adjacent: spec § PTCH). See [`ranges`].
#[derive(Clone, Debug)]
pub struct TriangleRanges<'v> {
    pvis: &'v Pvis<'v>,
    patches: Patches<'v>,
    pending: Option<(u32, u32)>,
    /// The last patch read and its range, `(patch, first, count)`: a compact table finds the
    /// next range from it.
    last: Option<(u32, u32, u32)>,
}

impl TriangleRanges<'_> {
    /// The range of the next visible patch.
    fn next_patch(&mut self) -> Option<(u32, u32)> {
        let p = self.patches.next()?;
        let (first, count) = self.pvis.range_after(self.last, p);
        self.last = Some((p, first, count));
        Some((first, count))
    }
}

impl Iterator for TriangleRanges<'_> {
    type Item = (u32, u32);

    fn next(&mut self) -> Option<(u32, u32)> {
        let (first, mut count) = match self.pending.take() {
            Some(range) => range,
            None => self.next_patch()?,
        };
        while let Some((next_first, next_count)) = self.next_patch() {
            // Validated ranges sum to at most u32::MAX, so this cannot overflow.
            if next_first == first + count {
                count += next_count;
            } else {
                self.pending = Some((next_first, next_count));
                break;
            }
        }
        Some((first, count))
    }
}

/// The triangle ranges `(first, count)` of the patches in `visible`, ascending, adjacent
/// ranges merged: what a renderer draws.
pub fn ranges<'v>(pvis: &'v Pvis<'_>, visible: &'v Visible<'_>) -> TriangleRanges<'v> {
    ranges_of_bits(pvis, visible.bits)
}

/// As [`ranges`], for a visible set given as its bits (patch `p` is bit `p % 64` of word
/// `p / 64`; bits past the last patch must be zero), e.g. an answer that crossed the C ABI.
pub fn ranges_of_bits<'v>(pvis: &'v Pvis<'_>, bits: &'v [u64]) -> TriangleRanges<'v> {
    // Shorten the borrows to one lifetime; both outlive the iterator.
    let pvis: &'v Pvis<'v> = pvis;
    TriangleRanges {
        pvis,
        patches: Patches {
            bits,
            word: 0,
            current: bits.first().copied().unwrap_or(0),
        },
        pending: None,
        last: None,
    }
}

/// Where the eye is relative to the sampling sphere and shells (spec § Query steps 1–3).
pub(super) enum Eye {
    /// A finite offset `d = eye − center`, and its band.
    Direction([f32; 3], Band),
    /// A non-finite offset: no direction to look up.
    Unknown,
}

/// § Query steps 1–3.
pub(super) fn classify(pvis: &Pvis<'_>, eye: [f32; 3]) -> Eye {
    let c = pvis.sampling.center;
    // Step 1: the offset from the centre, in binary32 like the bake's cameras.
    let d = [eye[0] - c[0], eye[1] - c[1], eye[2] - c[2]];
    if !d.iter().all(|x| x.is_finite()) {
        return Eye::Unknown;
    }
    // Step 3: in binary64, where the squares of binary32 values cannot overflow; taken in
    // integers, exactly as binary64 rounds (`exact.rs`).
    Eye::Direction(
        d,
        super::shells::band(d, pvis.sampling.distance, &pvis.shells),
    )
}

/// Where an answer comes from: the eye's band and the leaf (three corner views) on each of the
/// band's two shells ([`Band::shells`]; the same leaf twice where one shell answers).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct Place {
    pub band: Band,
    pub leaves: [[u32; 3]; 2],
}

/// Sets every patch's bit in `out` (one row), leaving the padding bits zero.
pub(super) fn fill_all(out: &mut [u64], patch_count: u32) {
    // Word by word (the bits of the patches below `patch_count`) rather than a fill and a fix
    // of the last word: one loop, and no `memset` in the embedded reader.
    for (i, word) in out.iter_mut().enumerate() {
        let left = patch_count.saturating_sub(64 * i as u32);
        *word = if left >= 64 { !0 } else { (1u64 << left) - 1 };
    }
}

/// The conservative answer of § Query step 2, reported in band `K + 1` with `leaf`, the views
/// of the leaf that the zero direction locates to on the innermost shell ([`origin_leaf`]; a
/// query mode that has its own way of finding it passes that).
pub(super) fn everything<'s>(pvis: &Pvis<'_>, out: &'s mut [u64], leaf: [u32; 3]) -> Visible<'s> {
    fill_all(out, pvis.patch_count);
    let place = Place {
        band: Band::innermost(pvis.shells.count()),
        leaves: [leaf; 2],
    };
    visible(pvis, place, out)
}

/// The views of the leaf face that point location gives the zero direction on the innermost
/// shell, which the conservative answer reports.
pub(super) fn origin_leaf(pvis: &Pvis<'_>) -> [u32; 3] {
    sphere::locate([0.0; 3], pvis.shell_level(pvis.shells.count())).views
}

/// Wraps a computed answer.
pub(super) fn visible<'s>(pvis: &Pvis<'_>, place: Place, bits: &'s [u64]) -> Visible<'s> {
    let k = pvis.shells.count();
    Visible {
        inside_sphere: place.band.band > k,
        band: place.band.band,
        shells: place.band.shells(k),
        leaf: place.leaves[0],
        inner_leaf: place.leaves[1],
        bits,
        patch_count: pvis.patch_count,
    }
}

pub(super) fn query<'s>(pvis: &Pvis<'_>, eye: [f32; 3], scratch: &'s mut [u64]) -> Visible<'s> {
    let words = pvis.row_words();
    assert!(
        scratch.len() >= words,
        "scratch holds {} words, {words} needed (Pvis::scratch_words)",
        scratch.len()
    );
    let out = &mut scratch[..words];
    let Eye::Direction(d, band) = classify(pvis, eye) else {
        return everything(pvis, out, origin_leaf(pvis));
    };
    // § Query steps 4–5, on each shell of the band; its rows are OR-ed into the one answer row
    // (lock step: no scratch beyond it).
    out.fill(0);
    let shells = band.shells(pvis.shells.count());
    let mut leaves = [[0; 3]; 2];
    for (i, &s) in shells.iter().enumerate() {
        if i == 1 && s == shells[0] {
            leaves[1] = leaves[0];
            break;
        }
        leaves[i] = sphere::locate(d, pvis.shell_level(s)).views;
        pvis.or_shell_rows(s, &leaves[i], out);
    }
    visible(pvis, Place { band, leaves }, out)
}
