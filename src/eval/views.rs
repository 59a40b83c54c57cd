//! Where the evaluation looks from: seeded random directions on the sphere, a smooth orbit,
//! and camera paths read from a text file.
//!
//! Random directions use SplitMix64 (Steele et al. 2014) and `libm`'s `sin`/`cos`, so a seed
//! gives the same views on every platform. A direction is uniform on the unit sphere
//! (Archimedes: `z` uniform in `[-1, 1]`, azimuth uniform). Cost: O(1) per view.

pub use crate::splitmix::SplitMix64;

use crate::sampler::{Camera, NEAR_FRACTION};

/// Mixed into `--seed` for [`jitter_looks`], so that its stream differs from the views' own.
const LOOK_JITTER_STREAM: u64 = 0x6A17_7E12_100C_0001;

/// `count` unit directions drawn uniformly on the sphere from `seed`.
pub fn random_directions(count: u32, seed: u64) -> Vec<[f32; 3]> {
    let mut rng = SplitMix64::new(seed);
    (0..count)
        .map(|_| {
            let z = 2.0 * rng.next_f64() - 1.0;
            let azimuth = core::f64::consts::TAU * rng.next_f64();
            let ring = libm::sqrt((1.0 - z * z).max(0.0));
            [
                (ring * libm::cos(azimuth)) as f32,
                (ring * libm::sin(azimuth)) as f32,
                z as f32,
            ]
        })
        .collect()
}

/// `cameras` with each view direction turned by a seeded random angle of up to `max_deg`
/// degrees, uniform over the spherical cap of that radius around it (`eval --look-jitter`):
/// same eye, field of view, resolution and near plane. `max_deg = 0` gives the cameras back
/// unchanged, bit for bit.
pub fn jitter_looks(cameras: &[Camera], max_deg: f64, seed: u64) -> Vec<Camera> {
    if max_deg <= 0.0 {
        return cameras.to_vec();
    }
    let mut rng = SplitMix64::new(seed ^ LOOK_JITTER_STREAM);
    let cos_max = libm::cos(max_deg.to_radians());
    cameras
        .iter()
        .map(|c| {
            let cos_t = 1.0 - rng.next_f64() * (1.0 - cos_max);
            let sin_t = libm::sqrt((1.0 - cos_t * cos_t).max(0.0));
            let phi = core::f64::consts::TAU * rng.next_f64();
            let (f, r, u) = (c.forward(), c.right(), c.up());
            let (a, b) = (sin_t * libm::cos(phi), sin_t * libm::sin(phi));
            // The eye–target distance the camera was made with (its near plane is a fixed
            // fraction of it), so the target stays as far away.
            let distance = c.near() / NEAR_FRACTION;
            let eye = c.eye();
            let target: [f32; 3] = core::array::from_fn(|k| {
                (eye[k] + distance * (cos_t * f[k] + a * r[k] + b * u[k])) as f32
            });
            let eye = eye.map(|v| v as f32);
            Camera::look_at(eye, target, c.fov_deg() as f32, c.resolution()).with_near(c.near())
        })
        .collect()
}

/// How far the orbit swings above and below the equator (the `y = 0` plane), degrees. Enough
/// to see the model from above and below during one turn; small enough that the camera's up
/// vector never needs to switch.
pub const ORBIT_ELEVATION_DEG: f64 = 30.0;

/// The most cameras one evaluation takes: random views, orbit frames or a path file's
/// cameras. Each is a full render of the mesh, so a million is days of work already; more
/// would only be a count the user mistyped, and the per-view results would outgrow memory.
pub const MAX_VIEWS: u32 = 1_000_000;

/// `frames` unit directions along one turn around the `+Y` axis that also swings by
/// [`ORBIT_ELEVATION_DEG`] up and down: a smooth, closed path.
pub fn orbit_directions(frames: u32) -> Vec<[f32; 3]> {
    (0..frames)
        .map(|i| {
            let turn = core::f64::consts::TAU * f64::from(i) / f64::from(frames.max(1));
            let elevation = ORBIT_ELEVATION_DEG.to_radians() * libm::sin(turn);
            let (s, c) = (libm::sin(elevation), libm::cos(elevation));
            [
                (c * libm::cos(turn)) as f32,
                s as f32,
                (c * libm::sin(turn)) as f32,
            ]
        })
        .collect()
}

/// One camera of a path file: where it is and what it looks at.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PathCamera {
    /// Eye position, model space.
    pub eye: [f32; 3],
    /// The point looked at; `None` means the model's bounding-sphere centre.
    pub target: Option<[f32; 3]>,
}

/// A line of a camera path file that is not a camera.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("line {line}: {message}")]
pub struct PathError {
    /// 1-based line number.
    pub line: usize,
    /// What was found and what was expected.
    pub message: String,
}

/// Reads a camera path: one camera per line, `EX EY EZ` (looking at the model's centre) or
/// `EX EY EZ TX TY TZ` (looking at the target), numbers separated by spaces or commas. Blank
/// lines and lines starting with `#` are skipped. The eye must differ from the target.
pub fn parse_camera_path(text: &str) -> Result<Vec<PathCamera>, PathError> {
    let mut cameras = Vec::new();
    for (index, raw) in text.lines().enumerate() {
        let line = index + 1;
        let content = raw.trim();
        if content.is_empty() || content.starts_with('#') {
            continue;
        }
        let fail = |message: String| PathError { line, message };
        let numbers = content
            .split(|c: char| c == ',' || c.is_whitespace())
            .filter(|t| !t.is_empty())
            .map(|t| match t.parse::<f32>() {
                Ok(v) if v.is_finite() => Ok(v),
                _ => Err(fail(format!("expected a finite number, found '{t}'"))),
            })
            .collect::<Result<Vec<f32>, PathError>>()?;
        let camera = match numbers.as_slice() {
            &[x, y, z] => PathCamera {
                eye: [x, y, z],
                target: None,
            },
            &[x, y, z, tx, ty, tz] => {
                if [x, y, z] == [tx, ty, tz] {
                    return Err(fail("the eye and the target coincide".into()));
                }
                PathCamera {
                    eye: [x, y, z],
                    target: Some([tx, ty, tz]),
                }
            }
            other => {
                return Err(fail(format!(
                    "expected 3 numbers (eye) or 6 (eye and target), found {}",
                    other.len()
                )));
            }
        };
        if cameras.len() == MAX_VIEWS as usize {
            return Err(fail(format!(
                "more than {MAX_VIEWS} cameras, the most an evaluation takes"
            )));
        }
        cameras.push(camera);
    }
    if cameras.is_empty() {
        return Err(PathError {
            line: text.lines().count(),
            message: "no cameras: expected at least one line 'X Y Z'".into(),
        });
    }
    Ok(cameras)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn random_directions_are_unit_seeded_and_spread() {
        let a = random_directions(2000, 7);
        assert_eq!(a, random_directions(2000, 7));
        assert_ne!(a, random_directions(2000, 8));
        let mut mean = [0.0f64; 3];
        for d in &a {
            let len = (d.iter().map(|c| f64::from(*c).powi(2)).sum::<f64>()).sqrt();
            assert!((len - 1.0).abs() < 1e-6);
            for k in 0..3 {
                mean[k] += f64::from(d[k]) / a.len() as f64;
            }
        }
        // Uniform on the sphere: each coordinate has mean 0 and standard deviation 1/√3, so
        // the mean of 2000 is within 4σ = 4 / √(3·2000) ≈ 0.052.
        assert!(mean.iter().all(|m| m.abs() < 0.052), "{mean:?}");
        // Both hemispheres of every axis are hit.
        for k in 0..3 {
            assert!(a.iter().any(|d| d[k] > 0.9) && a.iter().any(|d| d[k] < -0.9));
        }
    }

    #[test]
    fn orbit_is_closed_and_smooth() {
        let path = orbit_directions(120);
        assert_eq!(path.len(), 120);
        assert_eq!(path[0], [1.0, 0.0, 0.0]);
        let step = |a: [f32; 3], b: [f32; 3]| {
            (0..3)
                .map(|k| f64::from(a[k] - b[k]).powi(2))
                .sum::<f64>()
                .sqrt()
        };
        // Neighbouring frames, including last → first, are a small step apart.
        for i in 0..120 {
            assert!(step(path[i], path[(i + 1) % 120]) < 0.07);
        }
        let top = path.iter().map(|d| d[1]).fold(f32::MIN, f32::max);
        assert!((f64::from(top) - ORBIT_ELEVATION_DEG.to_radians().sin()).abs() < 1e-3);
    }

    #[test]
    fn camera_paths_parse_and_report_bad_lines() {
        let text = "# eye\n1 2 3\n\n4,5,6, 0,0,1\n";
        assert_eq!(
            parse_camera_path(text).unwrap(),
            vec![
                PathCamera {
                    eye: [1.0, 2.0, 3.0],
                    target: None
                },
                PathCamera {
                    eye: [4.0, 5.0, 6.0],
                    target: Some([0.0, 0.0, 1.0])
                },
            ]
        );
        let err = parse_camera_path("1 2 3\n1 2\n").unwrap_err();
        assert_eq!(err.line, 2);
        assert!(err.message.contains("found 2"), "{err}");
        assert_eq!(parse_camera_path("1 x 3").unwrap_err().line, 1);
        assert_eq!(parse_camera_path("1 2 3 1 2 3").unwrap_err().line, 1);
        assert!(parse_camera_path("# nothing\n").is_err());
    }
}
