//! Measures alternatives for coding the visibility matrix of a `.pvis` file (issue 5).
//!
//! Usage: `cargo run --release --example visb_measure -- FILE.pvis`. Prints the raw size,
//! zstd -19 and xz -9 of the raw row-major matrix (the zstd and liblzma crates, in process),
//! XOR residual against the parent prediction with gap varints, and the empirical conditional
//! entropy of each view's bits under several context sets (static per-level probabilities).
//!
//! Then the patch-order study (issue 5): patch numberings that could put co-visible patches
//! next to each other — normal-cone Morton order, sorts of the visibility signatures (the
//! patch's column), a greedy nearest-neighbour tour on the signatures' Hamming distance and its
//! 2-opt refinement — each with zstd / xz of the reordered raw matrix (the baseline moves with
//! the order too) and the cost of several contexts under static and adaptive probabilities;
//! plus two contexts that need more than the parents' rows (the patch's facing against the
//! view, the diamond's opposite corners). The greedy tour is O(P² · V / 64): seconds at 2000
//! patches.

use patchvis::format::encode_hierarchical;
use patchvis::runtime::Pvis;
use patchvis::sampler::VisibilityMatrix;
use patchvis::sphere::{level_of, parents};
use std::collections::HashMap;

fn bit(row: &[u64], p: usize) -> usize {
    (row[p / 64] >> (p % 64) & 1) as usize
}

/// Bytes of `data` after `zstd -19`.
fn zstd19(data: &[u8]) -> Option<usize> {
    zstd::bulk::compress(data, 19).ok().map(|c| c.len())
}

/// Bytes of `data` after `xz -9`.
fn xz9(data: &[u8]) -> Option<usize> {
    liblzma::encode_all(data, 9).ok().map(|c| c.len())
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
    show("zstd -19", zstd19(&raw));
    show("xz -9", xz9(&raw));
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
    show("XOR parent a, zstd -19", zstd19(&xz));

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
    orders_study(&rows, views, p, &pvis);
}

/// A context over the bits (one `usize` per patch, in coding order) of the parents `a`, `b`,
/// the view `x` itself (only bits before `i` may be looked at) and the patch index `i`.
type ContextFn = fn(&[usize], &[usize], &[usize], usize) -> usize;

/// Coded size in bytes of the matrix with bits taken in `order` and context `ctx` (below
/// `nctx`): under static per-(level, context) probabilities (the empirical entropy, table not
/// counted), and under adaptive per-(level, context) probabilities updated with shift 4 and 5
/// (LZMA style) — adapted across the whole matrix, which flatters them: a decodable file would
/// have to restart them per view.
fn model_cost(
    rows: &[Vec<u64>],
    views: u32,
    order: &[usize],
    ctx: ContextFn,
    nctx: usize,
) -> (f64, f64, f64) {
    let p = order.len();
    let mut counts = vec![[0u64; 2]; nctx * 8];
    let mut adaptive4 = 0.0f64;
    let mut adaptive5 = 0.0f64;
    let mut st4 = vec![2048u32; nctx * 8];
    let mut st5 = vec![2048u32; nctx * 8];
    let zero = vec![0usize; p];
    let perm_row = |r: &[u64]| -> Vec<usize> { order.iter().map(|&q| bit(r, q)).collect() };
    let prow: Vec<Vec<usize>> = rows.iter().map(|r| perm_row(r)).collect();
    for v in 0..views {
        let (a, b) = match parents(v) {
            None => (&zero, &zero),
            Some([a, b]) => (&prow[a as usize], &prow[b as usize]),
        };
        let x = &prow[v as usize];
        let l = level_of(v) as usize;
        for i in 0..p {
            let c = l * nctx + ctx(a, b, x, i);
            let xb = x[i];
            counts[c][xb] += 1;
            for (st, acc, sh) in [(&mut st4, &mut adaptive4, 4), (&mut st5, &mut adaptive5, 5)] {
                let p0 = st[c] as f64 / 4096.0;
                *acc -= if xb == 0 {
                    p0.log2()
                } else {
                    (1.0 - p0).log2()
                };
                if xb == 0 {
                    st[c] += (4096 - st[c]) >> sh;
                } else {
                    st[c] -= st[c] >> sh;
                }
                st[c] = st[c].clamp(31, 4065);
            }
        }
    }
    let mut bits = 0.0f64;
    for c in &counts {
        let n = (c[0] + c[1]) as f64;
        for &k in c {
            if k > 0 {
                bits -= k as f64 * (k as f64 / n).log2();
            }
        }
    }
    (bits / 8.0, adaptive4 / 8.0, adaptive5 / 8.0)
}

/// The patch-order study: see the module documentation.
fn orders_study(rows: &[Vec<u64>], views: u32, p: usize, pvis: &Pvis) {
    // Per-patch visibility signatures (columns).
    let sw = (views as usize).div_ceil(64);
    let mut sig = vec![vec![0u64; sw]; p];
    for v in 0..views as usize {
        for (q, column) in sig.iter_mut().enumerate() {
            if bit(&rows[v], q) == 1 {
                column[v / 64] |= 1 << (v % 64);
            }
        }
    }
    let ham =
        |a: &[u64], b: &[u64]| -> u32 { a.iter().zip(b).map(|(x, y)| (x ^ y).count_ones()).sum() };
    let identity: Vec<usize> = (0..p).collect();
    // Greedy nearest neighbour from the patch seen least.
    let greedy = {
        let start = (0..p)
            .min_by_key(|&q| sig[q].iter().map(|w| w.count_ones()).sum::<u32>())
            .unwrap();
        let mut used = vec![false; p];
        let mut order = vec![start];
        used[start] = true;
        let mut cur = start;
        for _ in 1..p {
            let next = (0..p)
                .filter(|&q| !used[q])
                .min_by_key(|&q| (ham(&sig[cur], &sig[q]), q))
                .unwrap();
            used[next] = true;
            order.push(next);
            cur = next;
        }
        order
    };
    // Sort by normal-cone axis: octahedral map of the axis, Morton order of the 16-bit cell.
    let cone = {
        let mut keyed: Vec<(u64, usize)> = (0..p)
            .map(|q| {
                let info = pvis.patch(q as u32);
                let [x, y, z] = info.cone_axis;
                let n = x.abs() + y.abs() + z.abs();
                let (mut u, mut w) = if n > 0.0 { (x / n, y / n) } else { (0.0, 0.0) };
                if z < 0.0 {
                    let (uu, ww) = (u, w);
                    u = (1.0 - ww.abs()) * uu.signum();
                    w = (1.0 - uu.abs()) * ww.signum();
                }
                let qu = (((u + 1.0) * 0.5 * 65535.0) as u64).min(65535);
                let qw = (((w + 1.0) * 0.5 * 65535.0) as u64).min(65535);
                let mut m = 0u64;
                for k in 0..16 {
                    m |= ((qu >> k) & 1) << (2 * k) | ((qw >> k) & 1) << (2 * k + 1);
                }
                (m, q)
            })
            .collect();
        keyed.sort();
        keyed.into_iter().map(|(_, q)| q).collect::<Vec<_>>()
    };
    let tour = |o: &[usize]| -> u64 {
        o.windows(2)
            .map(|w| ham(&sig[w[0]], &sig[w[1]]) as u64)
            .sum()
    };
    let ctxs: Vec<(&str, ContextFn, usize)> = vec![
        (
            "a,b,x-1,a-1,b-1 (current)",
            |a, b, x, i| {
                let pr = |r: &[usize]| if i > 0 { r[i - 1] } else { 0 };
                a[i] * 16 + b[i] * 8 + pr(x) * 4 + pr(a) * 2 + pr(b)
            },
            32,
        ),
        (
            "a,b,x-1,x-2,a-1,b-1",
            |a, b, x, i| {
                let pr = |r: &[usize], k: usize| if i >= k { r[i - k] } else { 0 };
                a[i] * 32 + b[i] * 16 + pr(x, 1) * 8 + pr(a, 1) * 4 + pr(b, 1) * 2 + pr(x, 2)
            },
            64,
        ),
        (
            "a,b,x-1,x-2,x-3,a-1,b-1",
            |a, b, x, i| {
                let pr = |r: &[usize], k: usize| if i >= k { r[i - k] } else { 0 };
                a[i] * 64
                    + b[i] * 32
                    + pr(x, 1) * 16
                    + pr(a, 1) * 8
                    + pr(b, 1) * 4
                    + pr(x, 2) * 2
                    + pr(x, 3)
            },
            128,
        ),
        (
            "a,b,x-1,x-2,a-1,b-1,a+1,b+1",
            |a, b, x, i| {
                let pr = |r: &[usize], k: usize| if i >= k { r[i - k] } else { 0 };
                let nx = |r: &[usize]| if i + 1 < r.len() { r[i + 1] } else { 0 };
                ((a[i] * 32 + b[i] * 16 + pr(x, 1) * 8 + pr(a, 1) * 4 + pr(b, 1) * 2 + pr(x, 2))
                    * 2
                    + nx(a))
                    * 2
                    + nx(b)
            },
            256,
        ),
    ];
    // 2-opt refinement of the greedy tour (segment reversals that shorten it).
    let two_opt = {
        let mut o = greedy.clone();
        let d = |a: usize, b: usize| ham(&sig[a], &sig[b]) as i64;
        for _round in 0..3 {
            let mut improved = false;
            for i in 0..p - 2 {
                for j in i + 2..p {
                    let before = d(o[i], o[i + 1]) + if j + 1 < p { d(o[j], o[j + 1]) } else { 0 };
                    let after = d(o[i], o[j]) + if j + 1 < p { d(o[i + 1], o[j + 1]) } else { 0 };
                    if after < before {
                        o[i + 1..=j].reverse();
                        improved = true;
                    }
                }
            }
            if !improved {
                break;
            }
        }
        o
    };
    // Facing: sign of the view direction against the patch's cone axis, in coding order.
    let facing_study = |order: &[usize], name: &str| {
        let axes: Vec<[f32; 3]> = order
            .iter()
            .map(|&q| pvis.patch(q as u32).cone_axis)
            .collect();
        let prow: Vec<Vec<usize>> = rows
            .iter()
            .map(|r| order.iter().map(|&q| bit(r, q)).collect())
            .collect();
        let mut counts: HashMap<(u32, usize), [u64; 2]> = HashMap::new();
        let mut counts4: HashMap<(u32, usize), [u64; 2]> = HashMap::new();
        let zero = vec![0usize; p];
        for v in 0..views {
            let dir = patchvis::sphere::direction(v);
            let (a, b) = match parents(v) {
                None => (&zero, &zero),
                Some([a, b]) => (&prow[a as usize], &prow[b as usize]),
            };
            let x = &prow[v as usize];
            for i in 0..p {
                let pr = |r: &[usize]| if i > 0 { r[i - 1] } else { 0 };
                let base = a[i] * 16 + b[i] * 8 + pr(x) * 4 + pr(a) * 2 + pr(b);
                let ax = axes[i];
                let dot = ax[0] * dir[0] + ax[1] * dir[1] + ax[2] * dir[2];
                let f = (dot > 0.0) as usize;
                let f4 = if dot < -0.5 {
                    0
                } else if dot < 0.0 {
                    1
                } else if dot < 0.5 {
                    2
                } else {
                    3
                };
                counts.entry((level_of(v), base * 2 + f)).or_default()[x[i]] += 1;
                counts4.entry((level_of(v), base * 4 + f4)).or_default()[x[i]] += 1;
            }
        }
        let h = |c: &HashMap<(u32, usize), [u64; 2]>| {
            let mut bits = 0.0f64;
            for c in c.values() {
                let n = (c[0] + c[1]) as f64;
                for &k in c {
                    if k > 0 {
                        bits -= k as f64 * (k as f64 / n).log2();
                    }
                }
            }
            bits / 8.0
        };
        println!(
            "  {name}: current + facing sign {:.0} B, + facing 4 buckets {:.0} B",
            h(&counts),
            h(&counts4)
        );
    };
    // Diamond: the two opposite vertices of the level-(l-1) triangles sharing the parent edge.
    let diamond = |v: u32| -> Option<[u32; 2]> {
        let lp = patchvis::sphere::lattice_point(v)?;
        if lp.level == 0 {
            return None;
        }
        let t = lp.coords.iter().position(|c| c % 2 == 0)?;
        let (iu, iw) = ((t + 1) % 3, (t + 2) % 3);
        let (e, u, w) = (lp.coords[t], lp.coords[iu], lp.coords[iw]);
        let (su, sw) = (u.signum(), w.signum());
        let mk = |et: i32, uu: i32, ww: i32| {
            let mut c = [0; 3];
            c[t] = et;
            c[iu] = uu;
            c[iw] = ww;
            patchvis::sphere::view_index(patchvis::sphere::LatticePoint {
                level: lp.level,
                coords: c,
            })
        };
        let (c, d) = if e > 0 {
            (mk(e + 2, u - su, w - sw), mk(e - 2, u + su, w + sw))
        } else if e < 0 {
            (mk(e - 2, u - su, w - sw), mk(e + 2, u + su, w + sw))
        } else {
            (mk(2, u - su, w - sw), mk(-2, u - su, w - sw))
        };
        Some([c, d])
    };
    let diamond_study = |order: &[usize], name: &str| {
        let prow: Vec<Vec<usize>> = rows
            .iter()
            .map(|r| order.iter().map(|&q| bit(r, q)).collect())
            .collect();
        let mut counts: HashMap<(u32, usize), [u64; 2]> = HashMap::new();
        let mut counts2: HashMap<(u32, usize), [u64; 2]> = HashMap::new();
        let zero = vec![0usize; p];
        for v in 0..views {
            let (a, b) = match parents(v) {
                None => (&zero, &zero),
                Some([a, b]) => (&prow[a as usize], &prow[b as usize]),
            };
            let (c, d) = match diamond(v) {
                None => (&zero, &zero),
                Some([c, d]) => (&prow[c as usize], &prow[d as usize]),
            };
            let x = &prow[v as usize];
            for i in 0..p {
                let pr = |r: &[usize]| if i > 0 { r[i - 1] } else { 0 };
                let base = a[i] * 16 + b[i] * 8 + pr(x) * 4 + pr(a) * 2 + pr(b);
                counts
                    .entry((level_of(v), base * 3 + c[i] + d[i]))
                    .or_default()[x[i]] += 1;
                let base2 = a[i] * 4 + b[i] * 2 + pr(x);
                counts2
                    .entry((level_of(v), base2 * 3 + c[i] + d[i]))
                    .or_default()[x[i]] += 1;
            }
        }
        let h = |c: &HashMap<(u32, usize), [u64; 2]>| {
            let mut bits = 0.0f64;
            for c in c.values() {
                let n = (c[0] + c[1]) as f64;
                for &k in c {
                    if k > 0 {
                        bits -= k as f64 * (k as f64 / n).log2();
                    }
                }
            }
            bits / 8.0
        };
        println!(
            "  {name}: current + c+d {:.0} B; a,b,x-1,c+d {:.0} B",
            h(&counts),
            h(&counts2)
        );
    };
    diamond_study(&identity, "identity");
    diamond_study(&two_opt, "2-opt");
    facing_study(&identity, "identity");
    facing_study(&greedy, "greedy");
    facing_study(&two_opt, "2-opt");
    // Signature sort: lexicographic on the column (view 0 first); and reflected (Gray) order.
    let lex = {
        let mut o: Vec<usize> = (0..p).collect();
        let key = |q: usize| -> Vec<u64> { sig[q].iter().map(|w| w.reverse_bits()).collect() };
        o.sort_by_key(|&q| (key(q), q));
        o
    };
    let gray = {
        // Gray rank: prefix-xor of bits in view order.
        let mut o: Vec<usize> = (0..p).collect();
        let key = |q: usize| -> Vec<u64> {
            let mut acc = 0u64;
            sig[q]
                .iter()
                .map(|w| {
                    let mut out = 0u64;
                    for k in 0..64 {
                        acc ^= w >> k & 1;
                        out |= acc << (63 - k);
                    }
                    out
                })
                .collect()
        };
        o.sort_by_key(|&q| (key(q), q));
        o
    };
    for (oname, order) in [
        ("identity", &identity),
        ("cone-axis Morton", &cone),
        ("signature lexicographic", &lex),
        ("signature Gray", &gray),
        ("greedy Hamming", &greedy),
        ("greedy Hamming + 2-opt", &two_opt),
    ] {
        let mut raw = Vec::new();
        for r in rows {
            let mut bytes = vec![0u8; p.div_ceil(8)];
            for (i, &q) in order.iter().enumerate() {
                bytes[i / 8] |= (bit(r, q) as u8) << (i % 8);
            }
            raw.extend(bytes);
        }
        println!(
            "order {oname}: tour hamming {}, zstd -19 {:?} B, xz -9 {:?} B",
            tour(order),
            zstd19(&raw),
            xz9(&raw)
        );
        for (cname, c, n) in &ctxs {
            let (st, a4, a5) = model_cost(rows, views, order, *c, *n);
            println!(
                "  {cname:<34} static {st:>8.0} B  adaptive4 {a4:>8.0} B  adaptive5 {a5:>8.0} B"
            );
        }
    }
}
