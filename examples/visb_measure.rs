//! Measures alternatives for coding the visibility matrix of a `.pvis` file (issue 5).
//!
//! Usage: `cargo run --release --example visb_measure -- FILE.pvis`. Prints the raw size,
//! zstd -19 and xz -9 of the raw row-major matrix (via the `zstd` / `xz` tools when installed),
//! XOR residual against the parent prediction with gap varints, and the empirical conditional
//! entropy of each view's bits under several context sets (static per-level probabilities).

use patchvis::format::encode_hierarchical;
use patchvis::runtime::Pvis;
use patchvis::sampler::VisibilityMatrix;
use patchvis::sphere::{level_of, parents};
use std::collections::HashMap;
use std::io::Write;
use std::process::{Command, Stdio};

fn bit(row: &[u64], p: usize) -> usize {
    (row[p / 64] >> (p % 64) & 1) as usize
}

fn external(tool: &str, args: &[&str], data: &[u8]) -> Option<usize> {
    let mut child = Command::new(tool)
        .args(args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .spawn()
        .ok()?;
    child.stdin.take()?.write_all(data).ok()?;
    Some(child.wait_with_output().ok()?.stdout.len())
}

fn main() {
    let path = std::env::args()
        .nth(1)
        .expect("usage: visb_measure FILE.pvis");
    let bytes = std::fs::read(&path).expect("read");
    let pvis = Pvis::parse(&bytes).expect("parse");
    let views = pvis.sampling().views;
    let p = pvis.patch_count() as usize;
    let words = pvis.row_words();
    let rows: Vec<Vec<u64>> = (0..views)
        .map(|v| {
            let mut r = vec![0; words];
            pvis.view_row(v, &mut r);
            r
        })
        .collect();
    let mut raw = Vec::new();
    for r in &rows {
        let mut b: Vec<u8> = r.iter().flat_map(|w| w.to_le_bytes()).collect();
        b.truncate(p.div_ceil(8));
        raw.extend(b);
    }
    let ones: usize = rows
        .iter()
        .map(|r| r.iter().map(|w| w.count_ones() as usize).sum::<usize>())
        .sum();
    println!(
        "{path}: {p} patches x {views} views, {:.1}% bits set",
        100.0 * ones as f64 / (p * views as usize) as f64
    );
    println!("raw                       {:>8} B", raw.len());
    let show = |name: &str, size: Option<usize>| match size {
        Some(s) => println!("{name:<26}{s:>8} B"),
        None => println!("{name:<26}     n/a (tool missing)"),
    };
    show("zstd -19", external("zstd", &["-19", "-c", "-q"], &raw));
    show("xz -9", external("xz", &["-9", "-c", "-q"], &raw));
    show("VISB in this file", Some(pvis.visibility_bytes() as usize));
    let mut matrix = VisibilityMatrix::new(views, p as u32);
    for v in 0..views {
        matrix.row_mut(v).copy_from_slice(&rows[v as usize]);
    }
    let coded = encode_hierarchical(&matrix, pvis.sampling().level);
    show("VISB encoding 1 (ours)", Some(coded.len()));

    // XOR against the first parent's row, the positions of differing bits as gap varints.
    let mut xor_bytes = 0usize;
    for v in 0..views {
        let pred = |i: usize| match parents(v) {
            None => 0,
            // Where the parents agree this is their bit; where they differ, no parent is a
            // better guess than the other.
            Some([a, _]) => bit(&rows[a as usize], i),
        };
        let mut last = 0usize;
        let mut n = 0usize;
        for i in 0..p {
            if bit(&rows[v as usize], i) != pred(i) {
                let gap = i - last;
                xor_bytes += 1 + (gap >= 128) as usize + (gap >= 16384) as usize;
                last = i;
                n += 1;
            }
        }
        xor_bytes += 1 + (n >= 128) as usize + (n >= 16384) as usize;
    }
    show("XOR residual + gap varints", Some(xor_bytes));
    let mut xz = Vec::new();
    for v in 0..views {
        let r = &rows[v as usize];
        let pr: Vec<u64> = match parents(v) {
            None => vec![0; words],
            Some([a, _]) => rows[a as usize].clone(),
        };
        let mut b: Vec<u8> = r
            .iter()
            .zip(&pr)
            .flat_map(|(x, y)| (x ^ y).to_le_bytes())
            .collect();
        b.truncate(p.div_ceil(8));
        xz.extend(b);
    }
    show(
        "XOR parent a, zstd -19",
        external("zstd", &["-19", "-c", "-q"], &xz),
    );

    // Empirical conditional entropy: context = f(a, b, neighbours); static probabilities per
    // (level, context).
    type Ctx = fn(&[u64], &[u64], &[u64], usize) -> usize;
    let sets: Vec<(&str, Ctx)> = vec![
        ("a,b", |a, b, _x, i| bit(a, i) * 2 + bit(b, i)),
        ("a+b", |a, b, _x, i| bit(a, i) + bit(b, i)),
        ("a,b,x-1", |a, b, x, i| {
            let xp = if i > 0 { bit(x, i - 1) } else { 0 };
            (bit(a, i) * 2 + bit(b, i)) * 2 + xp
        }),
        ("a,b,x-1,a-1,b-1", |a, b, x, i| {
            let (xp, ap, bp) = if i > 0 {
                (bit(x, i - 1), bit(a, i - 1), bit(b, i - 1))
            } else {
                (0, 0, 0)
            };
            (((bit(a, i) * 2 + bit(b, i)) * 2 + xp) * 2 + ap) * 2 + bp
        }),
        ("a,b,x-1,x-2,a-1,b-1", |a, b, x, i| {
            let (xp, ap, bp) = if i > 0 {
                (bit(x, i - 1), bit(a, i - 1), bit(b, i - 1))
            } else {
                (0, 0, 0)
            };
            let xq = if i > 1 { bit(x, i - 2) } else { 0 };
            ((((bit(a, i) * 2 + bit(b, i)) * 2 + xp) * 2 + ap) * 2 + bp) * 2 + xq
        }),
        ("a,b,x-1,a-1,b-1,a+1,b+1", |a, b, x, i| {
            let (xp, ap, bp) = if i > 0 {
                (bit(x, i - 1), bit(a, i - 1), bit(b, i - 1))
            } else {
                (0, 0, 0)
            };
            let n = a.len() * 64;
            let (an, bn) = if i + 1 < n {
                (bit(a, i + 1), bit(b, i + 1))
            } else {
                (0, 0)
            };
            ((((bit(a, i) * 2 + bit(b, i)) * 2 + xp) * 2 + ap) * 2 + bp) * 4 + an * 2 + bn
        }),
        ("ab,x-1 agree(a-1,b-1),x-1==a-1", |a, b, x, i| {
            let (xp, ap, bp) = if i > 0 {
                (bit(x, i - 1), bit(a, i - 1), bit(b, i - 1))
            } else {
                (0, 0, 0)
            };
            ((bit(a, i) * 2 + bit(b, i)) * 2 + xp) * 4 + (ap ^ xp) * 2 + (bp ^ xp)
        }),
    ];
    let zero = vec![0u64; words];
    for (name, ctx) in &sets {
        let mut counts: HashMap<(u32, usize), [u64; 2]> = HashMap::new();
        for v in 0..views {
            let (a, b) = match parents(v) {
                None => (&zero, &zero),
                Some([a, b]) => (&rows[a as usize], &rows[b as usize]),
            };
            let x = &rows[v as usize];
            for i in 0..p {
                counts.entry((level_of(v), ctx(a, b, x, i))).or_default()[bit(x, i)] += 1;
            }
        }
        let mut bits = 0.0f64;
        for c in counts.values() {
            let n = (c[0] + c[1]) as f64;
            for &k in c {
                if k > 0 {
                    bits -= k as f64 * (k as f64 / n).log2();
                }
            }
        }
        println!(
            "H(x | {name:<30}) {:>8.0} B  ({} contexts used)",
            bits / 8.0,
            counts.len()
        );
    }
}
