//! Stable vertex numbering of the subdivided octahedron.
//!
//! A vertex of level `l` is an integer lattice point `(i, j, k)` with `|i| + |j| + |k| = 2^l`
//! (the octahedron's faces are the octants of that lattice). The midpoint of an edge `(a, b)`
//! of level `l` is the lattice point `a + b` of level `l + 1`, so a vertex's identity never
//! depends on which face created it. A vertex new at level `l ≥ 1` has exactly two odd
//! coordinates; its parents are the two level-`l - 1` points one step away along them.
//!
//! Indices: level 0 is `+X, −X, +Y, −Y, +Z, −Z` (0..6); the vertices new at level `l` follow
//! all of level `l − 1`'s, grouped by which coordinate `t` is even, then by rings of constant
//! even coordinate `e` (ascending), then along the ring. Cost: O(2^l) for the ring walk.

use super::{MAX_LEVEL, ViewIndex, add, normalize, view_count};

/// A sphere vertex as an integer lattice point of a level: `|i| + |j| + |k| = 2^level`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct LatticePoint {
    /// The level whose lattice `coords` is in.
    pub level: u32,
    /// The coordinates.
    pub coords: [i32; 3],
}

impl LatticePoint {
    /// The same vertex expressed at the coarsest level where it exists.
    pub fn reduced(self) -> LatticePoint {
        let mut p = self;
        while p.level > 0 && p.coords.iter().all(|c| c % 2 == 0) {
            p.coords = p.coords.map(|c| c / 2);
            p.level -= 1;
        }
        p
    }

    /// The same vertex one level finer (coordinates doubled).
    pub fn refined(self) -> LatticePoint {
        LatticePoint {
            level: self.level + 1,
            coords: self.coords.map(|c| c * 2),
        }
    }
}

const LEVEL0: [[i32; 3]; 6] = [
    [1, 0, 0],
    [-1, 0, 0],
    [0, 1, 0],
    [0, -1, 0],
    [0, 0, 1],
    [0, 0, -1],
];

/// The view index of lattice point `p`. `p` must lie on its level's octahedron
/// (`|i| + |j| + |k| = 2^level`, `level ≤ MAX_LEVEL`); this is asserted in debug builds.
pub fn view_index(p: LatticePoint) -> ViewIndex {
    let p = p.reduced();
    debug_assert!(p.level <= MAX_LEVEL);
    debug_assert_eq!(
        p.coords.iter().map(|c| c.unsigned_abs()).sum::<u32>(),
        1 << p.level
    );
    if p.level == 0 {
        // LEVEL0's order: axis t's positive end is 2t, its negative end 2t + 1.
        let t = p.coords.iter().position(|&c| c != 0).unwrap_or(0);
        return (2 * t + usize::from(p.coords[t] < 0)) as ViewIndex;
    }
    let n = 1i32 << p.level;
    // Exactly one coordinate is even (the sum of |c| is even and not all are even).
    let t = p.coords.iter().position(|c| c % 2 == 0).unwrap_or(0);
    let e = p.coords[t];
    let u = p.coords[(t + 1) % 3];
    let w = p.coords[(t + 2) % 3];
    let m = n - e.abs();
    let along = 2 * ((u + m - 1) / 2) + i32::from(w > 0);
    let within = ring_start(n, e) + along;
    view_count(p.level - 1) + t as u32 * (n * n) as u32 + within as u32
}

/// Number of type-`t` vertices in the rings before the ring of even coordinate `e`.
fn ring_start(n: i32, e: i32) -> i32 {
    let mut start = 0;
    let mut ring = -(n - 2);
    while ring < e {
        start += 2 * (n - ring.abs());
        ring += 2;
    }
    start
}

/// The level at which `view` first appears. `view` must be below `view_count(MAX_LEVEL)`.
pub fn level_of(view: ViewIndex) -> u32 {
    (0..=MAX_LEVEL)
        .find(|&l| view < view_count(l))
        .unwrap_or(MAX_LEVEL)
}

/// The lattice point of `view` at its own level, or `None` if `view` is beyond
/// `view_count(MAX_LEVEL)`.
pub fn lattice_point(view: ViewIndex) -> Option<LatticePoint> {
    if view >= view_count(MAX_LEVEL) {
        return None;
    }
    let level = level_of(view);
    if level == 0 {
        return Some(LatticePoint {
            level,
            coords: LEVEL0[view as usize],
        });
    }
    let n = 1i32 << level;
    let mut rest = (view - view_count(level - 1)) as i32;
    let t = (rest / (n * n)) as usize;
    rest %= n * n;
    let mut e = -(n - 2);
    loop {
        let m = n - e.abs();
        if rest < 2 * m {
            let u = 2 * (rest / 2) - (m - 1);
            let w_abs = m - u.abs();
            let w = if rest % 2 == 1 { w_abs } else { -w_abs };
            let mut coords = [0; 3];
            coords[t] = e;
            coords[(t + 1) % 3] = u;
            coords[(t + 2) % 3] = w;
            return Some(LatticePoint { level, coords });
        }
        rest -= 2 * m;
        e += 2;
    }
}

/// The two views whose sphere edge `view` splits, or `None` for the six level-0 views (and
/// for indices beyond `view_count(MAX_LEVEL)`). The smaller index comes first.
pub fn parents(view: ViewIndex) -> Option<[ViewIndex; 2]> {
    let p = lattice_point(view)?;
    if p.level == 0 {
        return None;
    }
    let t = p.coords.iter().position(|c| c % 2 == 0)?;
    let (iu, iw) = ((t + 1) % 3, (t + 2) % 3);
    let (u, w) = (p.coords[iu], p.coords[iw]);
    // Step one unit along the two odd coordinates, keeping their signs: |u| ± 1, |w| ∓ 1.
    let step = |c: i32, delta: i32| c.signum() * (c.abs() + delta);
    let mut a = p.coords;
    a[iu] = step(u, 1);
    a[iw] = step(w, -1);
    let mut b = p.coords;
    b[iu] = step(u, -1);
    b[iw] = step(w, 1);
    let level = p.level;
    let ia = view_index(LatticePoint { level, coords: a });
    let ib = view_index(LatticePoint { level, coords: b });
    Some([ia.min(ib), ia.max(ib)])
}

/// Unit direction of `view` from the sphere centre: the level-0 axes, then
/// `normalize(direction(a) + direction(b))` for a view splitting edge `(a, b)`.
/// `view` must be below `view_count(MAX_LEVEL)` (larger indices give +X).
pub fn direction(view: ViewIndex) -> [f32; 3] {
    match parents(view) {
        None => {
            let c = LEVEL0[(view as usize).min(5)];
            if view < 6 {
                c.map(|x| x as f32)
            } else {
                [1.0, 0.0, 0.0]
            }
        }
        Some([a, b]) => normalize(add(direction(a), direction(b))),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn index_is_a_bijection_with_level_prefixes() {
        for level in 0..=5u32 {
            let n = 1i32 << level;
            let mut seen = vec![false; view_count(level) as usize];
            for i in -n..=n {
                for j in -(n - i.abs())..=(n - i.abs()) {
                    let rest = n - i.abs() - j.abs();
                    for k in if rest == 0 {
                        vec![0]
                    } else {
                        vec![-rest, rest]
                    } {
                        let p = LatticePoint {
                            level,
                            coords: [i, j, k],
                        };
                        let v = view_index(p);
                        assert!(v < view_count(level), "{p:?} -> {v}");
                        assert!(!seen[v as usize], "{p:?} -> {v} twice");
                        seen[v as usize] = true;
                        assert_eq!(lattice_point(v), Some(p.reduced()));
                        // Points that exist at a coarser level keep that level's index.
                        assert_eq!(view_index(p.reduced()), v);
                    }
                }
            }
            assert!(seen.iter().all(|&s| s), "level {level} not onto");
        }
    }

    #[test]
    fn view_counts_follow_the_paper() {
        let counts: Vec<u32> = (0..=5).map(view_count).collect();
        assert_eq!(counts, [6, 18, 66, 258, 1026, 4098]);
    }

    #[test]
    fn first_level_parents_are_the_octahedron_edges() {
        // Level 1 adds the 12 edge midpoints of the octahedron; each joins two axes that are
        // not opposite.
        let mut pairs: Vec<[u32; 2]> = (6..18).map(|v| parents(v).unwrap()).collect();
        pairs.sort();
        pairs.dedup();
        assert_eq!(pairs.len(), 12);
        for [a, b] in pairs {
            assert!(a < 6 && b < 6 && a / 2 != b / 2, "{a} {b}");
        }
        assert_eq!(parents(5), None);
    }

    #[test]
    fn parents_are_one_level_up_and_directions_unit() {
        for v in 6..view_count(5) {
            let [a, b] = parents(v).unwrap();
            assert_eq!(level_of(a).max(level_of(b)), level_of(v) - 1, "view {v}");
            let d = direction(v);
            let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            assert!((len - 1.0).abs() < 1e-6);
            // The midpoint lies between its parents.
            let (da, db) = (direction(a), direction(b));
            let dot = |x: [f32; 3], y: [f32; 3]| x[0] * y[0] + x[1] * y[1] + x[2] * y[2];
            assert!((dot(d, da) - dot(d, db)).abs() < 1e-5);
        }
    }
}
