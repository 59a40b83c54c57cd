//! Would coding a near shell's rows given the next shell out pay? (spec § SHEL, Rationale.)
//!
//! For each shell of a version-5 file, the empirical entropy of its rows under three static
//! models, counted over every bit of every view: encoding 1's context (the two parents' bits
//! at the patch and the one before, the view's previous bit; a table per level), the same
//! with the next shell out's bit at the same view and patch added (twice the contexts), and
//! the next shell out's bit with the view's previous bit alone. Entropy, not coded size: the
//! difference between the first two is the most that conditioning on the outer shell could
//! save before its table and the larger decoding closure. Also prints each shell's stored
//! payload for scale.
//!
//! ```text
//! cargo run --release --example shell_coding -- FILE.pvis
//! ```

use patchvis::runtime::Pvis;
use patchvis::sphere::{level_of, parents};

/// Counts of zeros and ones per context.
struct Counts(Vec<[u64; 2]>);

impl Counts {
    fn new(contexts: usize) -> Counts {
        Counts(vec![[0; 2]; contexts])
    }

    /// Entropy of the counted bits in bytes.
    fn bytes(&self) -> f64 {
        let mut bits = 0.0;
        for &[zeros, ones] in &self.0 {
            let n = (zeros + ones) as f64;
            for k in [zeros, ones] {
                if k > 0 {
                    bits -= k as f64 * (k as f64 / n).log2();
                }
            }
        }
        bits / 8.0
    }
}

fn bit(row: &[u64], p: i64) -> usize {
    if p < 0 {
        0
    } else {
        (row[p as usize / 64] >> (p % 64) & 1) as usize
    }
}

fn main() {
    let path = std::env::args()
        .nth(1)
        .expect("usage: shell_coding FILE.pvis");
    let bytes = std::fs::read(&path).expect("readable file");
    let pvis = Pvis::parse(&bytes).expect("a valid .pvis file");
    let words = pvis.row_words();
    let patches = i64::from(pvis.patch_count());
    // Every row of every shell, outermost first (the sampling sphere among them).
    let rows: Vec<Vec<Vec<u64>>> = (0..=pvis.shell_count())
        .map(|s| {
            (0..pvis.shell(s).views)
                .map(|v| {
                    let mut row = vec![0; words];
                    pvis.shell_view_row(s, v, &mut row);
                    row
                })
                .collect()
        })
        .collect();
    println!("{path}: {} patches, {} shells", patches, pvis.shell_count());
    println!("shell | stored payload | H(parents) | H(parents, outer) | H(outer, previous)");
    for s in 1..=pvis.shell_count() as usize {
        let (shell, outer) = (&rows[s], &rows[s - 1]);
        let levels = level_of(shell.len() as u32 - 1) as usize + 1;
        let (mut plain, mut with_outer, mut outer_only) = (
            Counts::new(32 * levels),
            Counts::new(64 * levels),
            Counts::new(4),
        );
        for (v, row) in shell.iter().enumerate() {
            let v = v as u32;
            let level = level_of(v) as usize;
            let zero = vec![0u64; words];
            let (a, b) = match parents(v) {
                Some([a, b]) => (&shell[a as usize], &shell[b as usize]),
                None => (&zero, &zero),
            };
            // The outer shell has this view when its level is at least the shell's.
            let o = outer.get(v as usize).unwrap_or(&zero);
            for p in 0..patches {
                let c = 16 * bit(a, p)
                    + 8 * bit(b, p)
                    + 4 * bit(row, p - 1)
                    + 2 * bit(a, p - 1)
                    + bit(b, p - 1);
                let x = bit(row, p);
                plain.0[32 * level + c][x] += 1;
                with_outer.0[64 * level + 2 * c + bit(o, p)][x] += 1;
                outer_only.0[2 * bit(o, p) + bit(row, p - 1)][x] += 1;
            }
        }
        println!(
            "{s} | {} B | {:.0} B | {:.0} B | {:.0} B",
            pvis.shell(s as u32).bytes,
            plain.bytes(),
            with_outer.bytes(),
            outer_only.bytes()
        );
    }
}
