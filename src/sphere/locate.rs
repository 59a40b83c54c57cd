//! The face hierarchy and point location (Meruvia 2002, §3.3.1).
//!
//! 8 root faces, one per octant; each face `(a, b, c)` (counter-clockwise seen from outside)
//! has 4 children in a fixed order: `(a, m_ab, m_ca)`, `(m_ab, b, m_bc)`, `(m_ca, m_bc, c)`,
//! `(m_ab, m_bc, m_ca)`, where `m_xy` is the midpoint vertex of edge `xy`. Spherical faces are
//! bounded by great circles, so the children tile their parent exactly, and descending from
//! the root finds the leaf under a direction with 3 sign tests per level.

use super::{LatticePoint, ViewIndex, add, cross, dot, normalize, view_index};

/// A face of the subdivided octahedron: three views, counter-clockwise seen from outside.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Face {
    /// The corner views.
    pub views: [ViewIndex; 3],
    /// The corner directions (unit vectors), computed as the spec prescribes.
    pub directions: [[f32; 3]; 3],
    /// The corners as lattice points of the face's level.
    pub lattice: [LatticePoint; 3],
}

impl Face {
    /// The face's subdivision level.
    pub fn level(&self) -> u32 {
        self.lattice[0].level
    }
}

/// The 8 faces of the octahedron, indexed by octant: bit 0 set for −X, bit 1 for −Y, bit 2
/// for −Z.
pub fn root_faces() -> [Face; 8] {
    core::array::from_fn(root_face)
}

/// The root face of `octant` (see [`root_faces`]; bits above the third are ignored). One at
/// a time, so point location numbers the 3 views of its octant rather than all 24.
pub fn root_face(octant: usize) -> Face {
    let s = [
        1 - 2 * (octant as i32 & 1),
        1 - 2 * (octant as i32 >> 1 & 1),
        1 - 2 * (octant as i32 >> 2 & 1),
    ];
    let x = [s[0], 0, 0];
    let y = [0, s[1], 0];
    let z = [0, 0, s[2]];
    // Counter-clockwise from outside is X, Y, Z in octants of positive orientation.
    let corners = if s[0] * s[1] * s[2] > 0 {
        [x, y, z]
    } else {
        [x, z, y]
    };
    let lattice = corners.map(|coords| LatticePoint { level: 0, coords });
    Face {
        views: lattice.map(view_index),
        directions: corners.map(|c| c.map(|v| v as f32)),
        lattice,
    }
}

/// The 4 children of `face`, in the fixed order of the module documentation.
pub fn children(face: &Face) -> [Face; 4] {
    let mids = midpoints(face);
    core::array::from_fn(|k| child(face, k, mids))
}

/// Every leaf face of `level` (`8 · 4^level` of them): the root faces split by [`children`]
/// `level` times, in that order.
#[cfg(any(feature = "std", test))]
pub fn leaf_faces(level: u32) -> std::vec::Vec<Face> {
    let mut faces = root_faces().to_vec();
    for _ in 0..level {
        faces = faces.iter().flat_map(children).collect();
    }
    faces
}

/// The directions of the midpoints of `face`'s edges `ab`, `bc` and `ca`.
fn midpoints(face: &Face) -> [[f32; 3]; 3] {
    let [da, db, dc] = face.directions;
    [
        normalize(add(da, db)),
        normalize(add(db, dc)),
        normalize(add(dc, da)),
    ]
}

/// Child `k` of `face`, given the directions of its edge midpoints ([`midpoints`]). One child
/// at a time, so point location numbers 3 views a level rather than 12.
fn child(face: &Face, k: usize, [dab, dbc, dca]: [[f32; 3]; 3]) -> Face {
    let [a, b, c] = face.lattice.map(LatticePoint::refined);
    let mid = |p: LatticePoint, q: LatticePoint| LatticePoint {
        level: p.level,
        coords: [
            (p.coords[0] + q.coords[0]) / 2,
            (p.coords[1] + q.coords[1]) / 2,
            (p.coords[2] + q.coords[2]) / 2,
        ],
    };
    // The refined corners have even coordinates, so the halved sum is the midpoint exactly.
    let (mab, mbc, mca) = (mid(a, b), mid(b, c), mid(c, a));
    let [da, db, dc] = face.directions;
    let (lattice, directions) = match k {
        0 => ([a, mab, mca], [da, dab, dca]),
        1 => ([mab, b, mbc], [dab, db, dbc]),
        2 => ([mca, mbc, c], [dca, dbc, dc]),
        _ => ([mab, mbc, mca], [dab, dbc, dca]),
    };
    Face {
        views: lattice.map(view_index),
        directions,
        lattice,
    }
}

/// The leaf face at `level` containing direction `dir` (need not be normalised).
///
/// Root: the octant of `dir`, a component `≥ 0` counting as positive. Each level then tests
/// the three inner edges of the face in order — child 0 if `dir · (m_ab × m_ca) ≥ 0`, else
/// child 1 if `dir · (m_bc × m_ab) ≥ 0`, else child 2 if `dir · (m_ca × m_bc) ≥ 0`, else
/// child 3 — so a direction exactly on an edge or vertex resolves deterministically, and
/// every direction (even zero or NaN) lands in exactly one leaf.
///
/// ```
/// use patchvis::sphere::{locate, view_count};
///
/// let face = locate([0.3, 0.5, 0.8], 4);
/// assert_eq!(face.level(), 4);
/// assert!(face.views.iter().all(|&v| v < view_count(4))); // 1026 views at level 4
/// ```
pub fn locate(dir: [f32; 3], level: u32) -> Face {
    // `≥ 0` is positive; NaN compares false and so counts as negative.
    let negative = |c: f32| usize::from(c.partial_cmp(&0.0).is_none_or(|o| o.is_lt()));
    let octant = negative(dir[0]) | negative(dir[1]) << 1 | negative(dir[2]) << 2;
    let mut face = root_face(octant & 7);
    for _ in 0..level {
        face = child_containing(&face, dir);
    }
    face
}

/// The child of `face` containing `dir`, by the tests of [`locate`].
pub(crate) fn child_containing(face: &Face, dir: [f32; 3]) -> Face {
    let mids = midpoints(face);
    let [dab, dbc, dca] = mids;
    let which = if dot(dir, cross(dab, dca)) >= 0.0 {
        0
    } else if dot(dir, cross(dbc, dab)) >= 0.0 {
        1
    } else if dot(dir, cross(dca, dbc)) >= 0.0 {
        2
    } else {
        3
    };
    child(face, which, mids)
}

#[cfg(test)]
mod tests {
    use super::super::{direction, face_count, parents, view_count};
    use super::*;
    use crate::test_kit::rng::Rng;
    use proptest::prelude::*;

    fn inside(face: &Face, d: [f32; 3], slack: f32) -> bool {
        let [a, b, c] = face.directions;
        dot(d, cross(a, b)) >= -slack
            && dot(d, cross(b, c)) >= -slack
            && dot(d, cross(c, a)) >= -slack
    }

    #[test]
    fn hierarchy_covers_every_view_and_matches_numbering() {
        for level in 0..=5 {
            let faces = leaf_faces(level);
            assert_eq!(faces.len() as u32, face_count(level));
            let mut used = vec![false; view_count(level) as usize];
            for f in &faces {
                for k in 0..3 {
                    used[f.views[k] as usize] = true;
                    // The direction computed along the hierarchy equals `direction(view)`
                    // bit for bit.
                    assert_eq!(f.directions[k], direction(f.views[k]));
                }
                // Counter-clockwise seen from outside.
                let [a, b, c] = f.directions;
                let n = cross(
                    [b[0] - a[0], b[1] - a[1], b[2] - a[2]],
                    [c[0] - a[0], c[1] - a[1], c[2] - a[2]],
                );
                assert!(dot(n, a) > 0.0);
            }
            assert!(used.iter().all(|&u| u));
        }
    }

    #[test]
    fn children_midpoints_split_parent_edges() {
        for f in leaf_faces(3) {
            let kids = children(&f);
            let mab = kids[0].views[1];
            assert_eq!(
                parents(mab),
                Some([f.views[0].min(f.views[1]), f.views[0].max(f.views[1])])
            );
        }
    }

    #[test]
    fn sample_directions_locate_to_a_face_with_that_corner() {
        for level in 0..=5 {
            for v in 0..view_count(level) {
                let face = locate(direction(v), level);
                assert!(face.views.contains(&v), "view {v} level {level}: {face:?}");
            }
        }
    }

    #[test]
    fn leaf_corners_are_the_nearest_views() {
        // Seeded directions over the sphere: the view nearest to the direction is a corner of
        // its leaf except in slivers near the Voronoi boundaries of the triangulation, and the
        // nearest corner is never farther than one edge length.
        let level = 4;
        let views: Vec<[f32; 3]> = (0..view_count(level)).map(direction).collect();
        let mut rng = Rng::new(0x9E37_79B9_7F4A_7C15);
        let mut next = || rng.signed();
        let (mut hits, total) = (0, 4000);
        for _ in 0..total {
            let d = normalize([next(), next(), next()]);
            let face = locate(d, level);
            let nearest = (0..views.len())
                .max_by(|&a, &b| dot(d, views[a]).total_cmp(&dot(d, views[b])))
                .unwrap();
            hits += usize::from(face.views.contains(&(nearest as u32)));
            let best_corner = face
                .directions
                .iter()
                .map(|&c| dot(d, c))
                .fold(f32::MIN, f32::max);
            // Longest edge at level 4 is under 7 degrees: cos(7°) ≈ 0.9925.
            assert!(best_corner > 0.9925, "{d:?}: {best_corner}");
        }
        assert!(
            hits * 100 >= total * 97,
            "nearest view is a leaf corner in {hits}/{total}"
        );
    }

    #[test]
    fn degenerate_directions_do_not_panic() {
        for d in [
            [0.0; 3],
            [f32::NAN; 3],
            [f32::INFINITY, 0.0, 0.0],
            [-0.0, -0.0, 1.0],
        ] {
            let face = locate(d, 4);
            assert_eq!(face.level(), 4);
        }
    }

    proptest! {
        #[test]
        fn located_leaf_contains_the_direction(x in -1.0f32..1.0, y in -1.0f32..1.0, z in -1.0f32..1.0, level in 0u32..=6) {
            prop_assume!(x * x + y * y + z * z > 1e-6);
            let d = [x, y, z];
            let face = locate(d, level);
            prop_assert!(inside(&face, normalize(d), 1e-5));
            // Exactly one leaf contains it (away from edges, within rounding).
            if level <= 3 {
                let containing = leaf_faces(level).iter().filter(|f| inside(f, normalize(d), -1e-5)).count();
                prop_assert!(containing <= 1);
            }
        }
    }
}
