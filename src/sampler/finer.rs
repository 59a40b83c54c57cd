//! Where the finer views of a supersampled pass lie, and what each one needs: its direction,
//! the finished views that seed its render, and the stored views its row folds into.
//!
//! A pass one level finer than the stored level `L` renders level `L`'s views, then views in
//! between, each folded into the stored views around it (`supersample.rs`). Two layouts:
//! - [`FinerViews::Midpoints`]: the vertices of level `L + K` (at `K = 1`, the midpoints of
//!   level `L`'s edges, `12 · 4^L` of them). Each is seeded by its two `sphere::parents` and
//!   folds into the endpoints of the edge it lies on.
//! - [`FinerViews::Centroids`] (`K = 1` only): the centroids of level `L`'s leaf faces,
//!   `8 · 4^L` of them, two thirds as many. Each is seeded by its face's three corners and
//!   folds into them.
//!
//! Why centroids: every point of a face lies within a third of an edge of a corner or the
//! centroid, where the midpoints cover it within 0.29 of an edge with 1.5× the views; with
//! the probe (whose cells grow to match) they keep the fidelity and culling of the midpoints
//! on the zoo in two thirds of the renders (docs/benchmarks/quality-zoo.md, "Finer views at
//! the face centroids").
//!
//! **Numbering.** The pass keeps level `L + K`'s view indices, so that its matrix, its
//! checkpoints, shards and part files are those of a level-`L + K` pass: with centroids,
//! index `view_count(L) + j` is the centroid of `leaf_faces(L)[j]`, and the indices after the
//! last face name no view (their rows stay empty, nothing renders or folds them).
//!
//! A centroid's direction is the normalized sum of its corners' binary32 directions, in
//! binary64, rounded to binary32: the same bits on every machine.

use crate::sphere::{Face, ViewIndex, direction, leaf_faces, parents, view_count};

/// Where the finer views of a supersampled pass lie (`bake --finer-views`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum FinerViews {
    /// The vertices of the finer sphere levels (at one finer level, the stored edges'
    /// midpoints).
    #[default]
    Midpoints,
    /// The centroids of the stored level's leaf faces (one finer level only).
    Centroids,
}

impl FinerViews {
    /// Its name on the command line and in reports.
    pub fn name(self) -> &'static str {
        match self {
            FinerViews::Midpoints => "midpoints",
            FinerViews::Centroids => "centroids",
        }
    }
}

/// The views of one pass at `fine_level` whose finer views are folded into `level` (see the
/// module documentation): which indices name a view, and each one's direction, seeds and
/// fold targets.
#[derive(Clone, Debug)]
pub struct PassViews {
    level: u32,
    fine_level: u32,
    /// The leaf faces of `level` when the finer views are their centroids.
    faces: Option<Vec<Face>>,
}

/// The finished views that seed a view's render: those whose rows it draws first.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Seeds {
    /// A view of the sphere's first level: none.
    None,
    /// A sphere vertex: its two parents.
    Parents([ViewIndex; 2]),
    /// A face centroid: the face's corners.
    Corners([ViewIndex; 3]),
}

impl Seeds {
    /// The seeding views, as a slice.
    pub fn views(&self) -> &[ViewIndex] {
        match self {
            Seeds::None => &[],
            Seeds::Parents(p) => p,
            Seeds::Corners(c) => c,
        }
    }
}

impl PassViews {
    /// The views of a pass at `fine_level` folded into `level`, laid out as `finer` says.
    ///
    /// Panics (caller contract) if `fine_level < level`, or with centroids unless
    /// `fine_level == level + 1`.
    pub fn new(level: u32, fine_level: u32, finer: FinerViews) -> PassViews {
        assert!(
            fine_level >= level,
            "fine level {fine_level} is coarser than the stored level {level}"
        );
        let faces = match finer {
            FinerViews::Midpoints => None,
            FinerViews::Centroids => {
                assert_eq!(
                    fine_level,
                    level + 1,
                    "centroid views are one level finer than the stored level"
                );
                Some(leaf_faces(level))
            }
        };
        PassViews {
            level,
            fine_level,
            faces,
        }
    }

    /// The views of a sampling pass at `level`: with centroids, level `level − 1`'s views
    /// and the centroids of its faces; otherwise level `level`'s views, each seeded by its
    /// parents.
    ///
    /// Panics (caller contract) with centroids at level 0.
    pub fn pass(level: u32, finer: FinerViews) -> PassViews {
        match finer {
            FinerViews::Midpoints => PassViews::new(level, level, finer),
            FinerViews::Centroids => {
                assert!(level > 0, "centroid views need a coarser level");
                PassViews::new(level - 1, level, finer)
            }
        }
    }

    /// The stored level the finer views fold into.
    pub fn level(&self) -> u32 {
        self.level
    }

    /// The pass's level: its matrix has a slot for each of its views.
    pub fn fine_level(&self) -> u32 {
        self.fine_level
    }

    /// Slots of the pass's matrix: one per view of `fine_level`.
    pub fn slots(&self) -> u32 {
        view_count(self.fine_level)
    }

    /// One past the last index naming a view.
    pub fn end(&self) -> u32 {
        match &self.faces {
            None => view_count(self.fine_level),
            Some(faces) => view_count(self.level) + faces.len() as u32,
        }
    }

    /// The finer views (those beyond the stored level's), in index order.
    pub fn finer_range(&self) -> core::ops::Range<ViewIndex> {
        view_count(self.level)..self.end()
    }

    /// The face whose centroid view `u` is, with centroids.
    fn face(&self, u: ViewIndex) -> Option<&Face> {
        let faces = self.faces.as_ref()?;
        let j = u.checked_sub(view_count(self.level))?;
        faces.get(j as usize)
    }

    /// Whether index `u` names a view of the pass.
    pub fn exists(&self, u: ViewIndex) -> bool {
        u < self.end()
    }

    /// The unit direction of view `u` (which must exist).
    pub fn direction(&self, u: ViewIndex) -> [f32; 3] {
        match self.face(u) {
            None => direction(u),
            Some(face) => centroid(face),
        }
    }

    /// The views whose rows seed view `u`'s render (all of them have smaller indices).
    pub fn seeds(&self, u: ViewIndex) -> Seeds {
        match self.face(u) {
            Some(face) => Seeds::Corners(face.views),
            None => parents(u).map_or(Seeds::None, Seeds::Parents),
        }
    }

    /// The stored views whose rows receive finer view `u`'s (see
    /// `supersample::fold_targets`; a centroid's are its face's corners).
    pub fn targets(&self, u: ViewIndex) -> super::FoldTargets {
        match self.face(u) {
            Some(face) => super::FoldTargets::Face(face.views),
            None => super::fold_targets(u, self.level),
        }
    }

    /// Whether each view's seeds are its fold targets: true of the finer views one level
    /// finer than the stored level (both layouts), so a fold that drops what the targets
    /// hold drops what the seeds hold.
    pub fn seeds_are_targets(&self) -> bool {
        self.fine_level == self.level + 1
    }

    /// The largest angle (radians) between a finer view and a view seeding it: every point
    /// of a stored face lies within `1/√3` of it from a view of the pass (a third of an edge
    /// from a corner or the centroid; `1/√3` of a finer edge from a finer vertex).
    pub fn max_seed_angle(&self) -> f64 {
        let mut max = 0f64;
        // The views new at the finest level: the farthest from their seeds.
        let first = if self.fine_level == 0 {
            0
        } else {
            view_count(self.fine_level - 1)
        };
        for u in first..self.end() {
            let d = self.direction(u).map(f64::from);
            for &s in self.seeds(u).views() {
                let e = direction(s).map(f64::from);
                let dot = (d[0] * e[0] + d[1] * e[1] + d[2] * e[2]).clamp(-1.0, 1.0);
                max = max.max(dot.acos());
            }
        }
        if max == 0.0 {
            // Level 0 has no seeds: its views are a quarter turn apart.
            core::f64::consts::FRAC_PI_2
        } else {
            max
        }
    }
}

/// The direction of `face`'s centroid view: its corners' sum, normalized (see the module
/// documentation).
fn centroid(face: &Face) -> [f32; 3] {
    let d = face.directions;
    let sum: [f64; 3] =
        core::array::from_fn(|k| f64::from(d[0][k]) + f64::from(d[1][k]) + f64::from(d[2][k]));
    let length = (sum[0] * sum[0] + sum[1] * sum[1] + sum[2] * sum[2]).sqrt();
    sum.map(|x| (x / length) as f32)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sphere::locate;

    #[test]
    fn every_centroid_lies_in_its_face_and_folds_into_its_corners() {
        for level in 0..=4 {
            let views = PassViews::new(level, level + 1, FinerViews::Centroids);
            let faces = leaf_faces(level);
            assert_eq!(views.end() - view_count(level), faces.len() as u32);
            assert!(views.end() <= views.slots());
            for (j, face) in faces.iter().enumerate() {
                let u = view_count(level) + j as u32;
                let d = views.direction(u);
                assert_eq!(locate(d, level).views, face.views, "level {level} face {j}");
                assert_eq!(views.seeds(u), Seeds::Corners(face.views));
                assert_eq!(
                    views.targets(u),
                    crate::sampler::FoldTargets::Face(face.views)
                );
                assert!(face.views.iter().all(|&c| c < u));
            }
            assert!(!views.exists(views.end()));
            assert!(views.exists(views.end() - 1));
        }
    }

    #[test]
    fn midpoints_are_the_sphere_vertices() {
        let views = PassViews::new(2, 3, FinerViews::Midpoints);
        assert_eq!(views.end(), view_count(3));
        for u in 0..view_count(3) {
            assert_eq!(views.direction(u), direction(u));
            assert_eq!(
                views.seeds(u).views(),
                parents(u).as_ref().map_or(&[][..], |p| p)
            );
            assert_eq!(views.targets(u), crate::sampler::fold_targets(u, 2));
        }
    }

    #[test]
    fn a_face_lies_within_a_third_of_its_seed_angle_of_a_centroid_pass_view() {
        // Points spread over every face of level 2: the nearest of the corners and the
        // centroid is within max_seed_angle / √3 (with the rounding's margin).
        let level = 2;
        let views = PassViews::new(level, level + 1, FinerViews::Centroids);
        let bound = views.max_seed_angle() / 3f64.sqrt() * 1.0001;
        let angle = |a: [f32; 3], b: [f32; 3]| {
            let dot: f64 = (0..3).map(|k| f64::from(a[k]) * f64::from(b[k])).sum();
            let la: f64 = (0..3).map(|k| f64::from(a[k]).powi(2)).sum::<f64>().sqrt();
            let lb: f64 = (0..3).map(|k| f64::from(b[k]).powi(2)).sum::<f64>().sqrt();
            (dot / la / lb).clamp(-1.0, 1.0).acos()
        };
        for (j, face) in leaf_faces(level).iter().enumerate() {
            let c = views.direction(view_count(level) + j as u32);
            let steps = 12;
            for a in 0..=steps {
                for b in 0..=steps - a {
                    let w = [a, b, steps - a - b].map(|x| f64::from(x) / f64::from(steps));
                    let p: [f32; 3] = core::array::from_fn(|k| {
                        (0..3)
                            .map(|i| w[i] * f64::from(face.directions[i][k]))
                            .sum::<f64>() as f32
                    });
                    let nearest = face
                        .directions
                        .iter()
                        .chain([&c])
                        .map(|&s| angle(p, s))
                        .fold(f64::MAX, f64::min);
                    assert!(nearest <= bound, "face {j}: {nearest} > {bound}");
                }
            }
        }
    }
}
