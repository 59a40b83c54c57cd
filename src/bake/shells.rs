//! The sampling shells of a bake (`--shells`, `--shell-min`, `--shell-level`): where their
//! views are, and which camera distances each sampling pass answers for.
//!
//! A file answers queries from outside the sampling sphere (distance `D = R / sin(fov / 2)`
//! from the centre, `R` the bounding radius) with the sampling sphere's rows. Nearer cameras
//! are answered from `K` nested shells of near views (spec § SHEL, § Query): shell `s` at
//! `D_s = D · (F·R / D)^(s/K)` for `s = 1..=K`, geometric from `D` down to `F·R` (`F` =
//! `--shell-min`, default 1.1), each sampled like the sampling sphere but recording every
//! patch visible from its eye in any direction (`SamplingOptions::shell`). The radii are
//! computed in binary64 with `libm`'s `pow` (the same bits on every CPU, unlike the system's
//! `pow`, which may pick an FMA variant at run time), rounded to binary32 once, and must be
//! strictly decreasing and at least `R`.
//!
//! A query at a distance between two shells ORs the rows of both (spec § Query), so each
//! pass's rows answer for the band from the next shell in to the next shell out
//! (`SamplingOptions::band`): the sampling sphere `[D_1, D_0]`, shell `s` `[D_{s+1},
//! D_{s-1}]`, the innermost `[D_K, D_{K-1}]`; without shells, no band.
//!
//! The bake plan (`plan.rs`) lists the shells as spheres of views after the sampling sphere.
//!
//! Cost: each shell is one more sampling pass of the stored level (and its supersampling),
//! with the near views' extra frustums, and one more matrix in the file.

use crate::visibility::SamplingParams;

/// `--shells` unless given: two shells between the sampling sphere and 1.1 bounding radii
/// (1.70 R and 1.10 R at the default field of view). On the bunny two already answer every
/// band from 1.1 R out with ≥ 97.5 % identical views, and a third costs 20 KB of file for
/// +1.5 points (BENCHMARKS.md, "Near cameras").
pub const DEFAULT_SHELLS: u32 = 2;

/// `--shell-min` unless given: the innermost shell at 1.1 bounding radii, near enough that a
/// camera inside it is nearly touching the model (where drawing everything is the answer).
pub const DEFAULT_SHELL_MIN: f64 = 1.1;

/// Most `--shells`: the format's limit (spec § SHEL). Each is a whole sampling pass, and
/// beyond a few the geometric radii are so close that a shell adds time without new views.
pub const MAX_SHELLS: u32 = crate::runtime::consts::MAX_SHELLS;

/// The shells' camera distances, outermost first: `D · (min·R / D)^(s/count)` for `s =
/// 1..=count` (module documentation), for the sampling sphere `params`. The error (one line,
/// naming the flags) says why the radii cannot be used: not strictly decreasing from `D` in
/// binary32, or below the bounding radius.
pub fn shell_distances(
    params: &SamplingParams,
    count: u32,
    min_ratio: f64,
) -> Result<Vec<f32>, String> {
    let outer = params.distance();
    let (d, r) = (f64::from(outer), f64::from(params.radius));
    let inner = min_ratio * r;
    let mut distances = Vec::with_capacity(count as usize);
    let mut previous = outer;
    for s in 1..=count {
        let distance = (d * libm::pow(inner / d, f64::from(s) / f64::from(count))) as f32;
        if !(distance < previous && distance >= params.radius) {
            let outside = match s {
                1 => "the sampling sphere",
                _ => "the shell outside it",
            };
            return Err(format!(
                "--shells {count} --shell-min {min_ratio}: shell {s} would be at {distance} from \
                 the centre, {}; use fewer shells or a --shell-min between 1 and {:.3} (the \
                 sampling distance {outer} over the bounding radius {})",
                if distance >= previous {
                    format!("not inside {outside} (at {previous})")
                } else {
                    format!("inside the bounding radius {}", params.radius)
                },
                d / r,
                params.radius
            ));
        }
        distances.push(distance);
        previous = distance;
    }
    Ok(distances)
}

/// `--far-shells` unless given: the far band's shells at 2 and 256 sampling distances. The
/// outermost stands for every eye beyond it: from 256·D the rim is within 0.1° of the rim
/// seen from infinitely far (`asin(1 / (256 · 2.61))` at the default field of view). With
/// these two every zoo model keeps ≥ 98 % of views identical from `D` out to 1000·D; a
/// shell at 4·D too buys 2 points of culling between 2 and 16·D for 16 % more file and bake
/// time (docs/benchmarks/far-cameras.md).
pub const DEFAULT_FAR_SHELLS: [f64; 2] = [2.0, 256.0];

/// Largest `--far-shells` multiple: beyond it the narrow frustum of a far view (its field of
/// view `2·asin(R / distance)`) starts to lose depth precision in binary32.
pub const MAX_FAR_SHELL: f64 = 1024.0;

/// The far band's camera distances, innermost first: `D · f` for each multiple `f` of
/// `factors` (increasing), rounded to binary32 once. The error (one line, naming the flag)
/// says why they cannot be used: not strictly increasing from `D` in binary32 or not finite.
pub fn far_distances(params: &SamplingParams, factors: &[f64]) -> Result<Vec<f32>, String> {
    let d = params.distance();
    let mut previous = d;
    factors
        .iter()
        .map(|&f| {
            let distance = (f64::from(d) * f) as f32;
            if !(distance.is_finite() && distance > previous) {
                return Err(format!(
                    "--far-shells {f}: the shell would be at {distance} from the centre, not \
                     beyond {previous} in binary32; use multiples further apart"
                ));
            }
            previous = distance;
            Ok(distance)
        })
        .collect()
}

/// The camera distances `[nearest, farthest]` each pass answers for (module documentation):
/// the sampling sphere's first, then each shell's; all `None` without shells.
pub fn bands(outer: f32, shells: &[f32]) -> Vec<Option<[f32; 2]>> {
    if shells.is_empty() {
        return vec![None];
    }
    // Every sphere's distance, outermost first: D_0, D_1, …, D_K.
    let all: Vec<f32> = std::iter::once(outer)
        .chain(shells.iter().copied())
        .collect();
    let last = all.len() - 1;
    (0..=last)
        .map(|s| Some([all[(s + 1).min(last)], all[s.saturating_sub(1)]]))
        .collect()
}

/// The camera distances `[nearest, farthest]` each far shell's pass answers for, innermost
/// first (module documentation): from the next sphere in (the sampling sphere for the first)
/// to the next one out (its own distance for the outermost, which answers every eye beyond).
pub fn far_bands(outer: f32, far: &[f32]) -> Vec<Option<[f32; 2]>> {
    (0..far.len())
        .map(|j| {
            let inner = if j == 0 { outer } else { far[j - 1] };
            Some([inner, far[(j + 1).min(far.len() - 1)]])
        })
        .collect()
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    pub(crate) fn params(radius: f32) -> SamplingParams {
        SamplingParams {
            level: 2,
            resolution: 64,
            fov_deg: 45.0,
            center: [0.0; 3],
            radius,
        }
    }

    #[test]
    fn the_radii_are_geometric_from_the_sampling_distance_to_the_innermost() {
        let p = params(2.0);
        let d = f64::from(p.distance());
        let shells = shell_distances(&p, 3, 1.1).unwrap();
        assert_eq!(shells.len(), 3);
        for (s, &ds) in shells.iter().enumerate() {
            let expected = d * (1.1 * 2.0 / d).powf((s + 1) as f64 / 3.0);
            assert!(
                (f64::from(ds) - expected).abs() <= expected * 1e-7,
                "{s}: {ds}"
            );
        }
        assert_eq!(shells[2], (1.1f64 * 2.0) as f32);
        assert!(p.distance() > shells[0] && shells[0] > shells[1] && shells[1] > shells[2]);
        assert_eq!(shell_distances(&p, 0, 1.1).unwrap(), Vec::<f32>::new());
    }

    #[test]
    fn radii_that_collapse_or_fall_inside_the_model_are_refused() {
        let p = params(1.0);
        // The innermost at the radius itself is fine; below it is not.
        assert!(shell_distances(&p, 2, 1.0).is_ok());
        let err = shell_distances(&p, 2, 0.9).unwrap_err();
        assert!(err.contains("inside the bounding radius"), "{err}");
        // At the sampling distance the first shell is not inside the sphere.
        let ratio = f64::from(p.distance());
        let err = shell_distances(&p, 1, ratio).unwrap_err();
        assert!(err.contains("not inside"), "{err}");
        // So many shells so close together that binary32 cannot tell them apart.
        let err = shell_distances(&p, 8, ratio * (1.0 - 1e-9)).unwrap_err();
        assert!(err.contains("--shells 8"), "{err}");
    }

    #[test]
    fn each_pass_answers_from_the_next_shell_in_to_the_next_one_out() {
        assert_eq!(bands(10.0, &[]), vec![None]);
        assert_eq!(
            bands(10.0, &[5.0, 3.0, 2.0]),
            vec![
                Some([5.0, 10.0]),
                Some([3.0, 10.0]),
                Some([2.0, 5.0]),
                Some([2.0, 3.0])
            ]
        );
        assert_eq!(
            bands(10.0, &[4.0]),
            vec![Some([4.0, 10.0]), Some([4.0, 10.0])]
        );
    }
}
