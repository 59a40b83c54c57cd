//! Which views each shard of a sharded bake renders (`patchvis bake --shard I/N`), and the
//! shard a cluster scheduler gives a task (`--shard auto`).
//!
//! The views of a sampling pass are ordered along a Hilbert curve over the octahedral map of
//! the sphere (a view's lattice point `(i, j, k)` goes to `(i, j)`, the lower half folded out
//! to the corners), ties broken by view id, and cut into `N` runs of equal length: shard `I`
//! owns run `I`. Each shard so holds a compact region of the sphere, with about `1/N` of
//! every level's views (each level's views are spread evenly over the sphere). The sampler
//! seeds a view from its two parents, which lie next to it on a coarser level
//! (`sphere::parents`), so nearly all of them are in the same region: a shard renders its
//! views and their ancestors (`SamplingOptions::views`), and only the ancestors across its
//! region's border are rendered by two shards. Every view is seeded exactly as in the whole
//! bake, so its row is the same bit for bit.
//!
//! The split depends only on the level and `N`: every shard computes it alone, with no
//! coordination. Cost: O(V log V) for the V views of a pass (65,538 at most).

use crate::sphere::{lattice_point, view_count};

/// Environment variable giving the shard count next to a Kubernetes Indexed Job's
/// `JOB_COMPLETION_INDEX` (Kubernetes does not export `.spec.completions`).
pub const SHARD_COUNT_ENV: &str = "PATCHVIS_SHARD_COUNT";

/// Most shards a bake splits into: one view each at the finest sphere level (65,538 views);
/// a larger count would only add shards that own nothing.
pub const MAX_SHARDS: u32 = 1 << 16;

/// Shard `index` of `count` (`--shard I/N`, with `I` from 0 to `N - 1`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Shard {
    /// Which shard, below `count`.
    pub index: u32,
    /// How many shards the bake has, at least 1.
    pub count: u32,
}

/// A shard that cannot be used: a malformed `--shard`, or no scheduler in the environment.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct ShardError(pub String);

impl Shard {
    /// Shard `index` of `count`, checked.
    pub fn new(index: u32, count: u32) -> Result<Shard, ShardError> {
        if count == 0 || count > MAX_SHARDS || index >= count {
            return Err(ShardError(format!(
                "--shard {index}/{count}: expected I/N with N from 1 to {MAX_SHARDS} and I from \
                 0 to N - 1"
            )));
        }
        Ok(Shard { index, count })
    }

    /// Parses `I/N`.
    pub fn parse(text: &str) -> Result<Shard, ShardError> {
        let bad = || {
            ShardError(format!(
                "--shard {text}: expected I/N (shard I of N, I from 0 to N - 1) or auto"
            ))
        };
        let (i, n) = text.split_once('/').ok_or_else(bad)?;
        let i = i.trim().parse::<u32>().map_err(|_| bad())?;
        let n = n.trim().parse::<u32>().map_err(|_| bad())?;
        Shard::new(i, n)
    }

    /// The shard a scheduler gave this task, from the environment `var` reads:
    ///
    /// - a Slurm job array: `SLURM_ARRAY_TASK_ID`, less `SLURM_ARRAY_TASK_MIN` (0 if unset),
    ///   of `SLURM_ARRAY_TASK_COUNT` (or `MAX - MIN + 1`); the array must have step 1;
    /// - a Kubernetes Indexed Job: `JOB_COMPLETION_INDEX` of [`SHARD_COUNT_ENV`], which the
    ///   Job sets to its `completions`.
    pub fn from_env(var: impl Fn(&str) -> Option<String>) -> Result<Shard, ShardError> {
        let number = |name: &str| -> Result<Option<u32>, ShardError> {
            match var(name) {
                None => Ok(None),
                Some(text) => text.trim().parse::<u32>().map(Some).map_err(|_| {
                    ShardError(format!(
                        "--shard auto: {name}={text:?} is not a whole number"
                    ))
                }),
            }
        };
        if let Some(id) = number("SLURM_ARRAY_TASK_ID")? {
            if let Some(step) = number("SLURM_ARRAY_TASK_STEP")?
                && step != 1
            {
                return Err(ShardError(format!(
                    "--shard auto: the Slurm job array has step {step}; submit it as \
                     --array=0-<N-1> (step 1)"
                )));
            }
            let min = number("SLURM_ARRAY_TASK_MIN")?.unwrap_or(0);
            let count = match (
                number("SLURM_ARRAY_TASK_COUNT")?,
                number("SLURM_ARRAY_TASK_MAX")?,
            ) {
                (Some(count), _) => count,
                (None, Some(max)) if max >= min => max - min + 1,
                _ => {
                    return Err(ShardError(
                        "--shard auto: SLURM_ARRAY_TASK_ID is set but neither \
                         SLURM_ARRAY_TASK_COUNT nor SLURM_ARRAY_TASK_MAX; give --shard I/N"
                            .into(),
                    ));
                }
            };
            let index = id.checked_sub(min).ok_or_else(|| {
                ShardError(format!(
                    "--shard auto: SLURM_ARRAY_TASK_ID {id} is below SLURM_ARRAY_TASK_MIN {min}"
                ))
            })?;
            return Shard::new(index, count)
                .map_err(|e| ShardError(format!("--shard auto (from the Slurm job array): {e}")));
        }
        if let Some(index) = number("JOB_COMPLETION_INDEX")? {
            let count = number(SHARD_COUNT_ENV)?.ok_or_else(|| {
                ShardError(format!(
                    "--shard auto: JOB_COMPLETION_INDEX is set (a Kubernetes Indexed Job) but \
                     {SHARD_COUNT_ENV} is not; set it to the Job's completions"
                ))
            })?;
            return Shard::new(index, count).map_err(|e| {
                ShardError(format!(
                    "--shard auto (from the Kubernetes Indexed Job): {e}"
                ))
            });
        }
        Err(ShardError(format!(
            "--shard auto: no scheduler's shard in the environment (expected \
             SLURM_ARRAY_TASK_ID from a Slurm job array, or JOB_COMPLETION_INDEX with \
             {SHARD_COUNT_ENV} from a Kubernetes Indexed Job); give --shard I/N"
        )))
    }

    /// The views of a pass at sphere level `level` this shard owns, ascending (see the module
    /// documentation). The shards of one count own every view exactly once between them.
    pub fn views(self, level: u32) -> Vec<u32> {
        let total = view_count(level);
        let mut keyed: Vec<(u64, u32)> = (0..total).map(|v| (curve_key(v, level), v)).collect();
        keyed.sort_unstable();
        let cut = |i: u32| (u64::from(total) * u64::from(i) / u64::from(self.count)) as usize;
        let mut owned: Vec<u32> = keyed[cut(self.index)..cut(self.index + 1)]
            .iter()
            .map(|&(_, v)| v)
            .collect();
        owned.sort_unstable();
        owned
    }
}

impl std::fmt::Display for Shard {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

/// The position of view `view` (of a pass at `level`) along the Hilbert curve over the
/// octahedral map of the sphere.
fn curve_key(view: u32, level: u32) -> u64 {
    let point = lattice_point(view).expect("a view of the pass");
    let side = 1i64 << level;
    let [i, j, k] = point.coords.map(|c| i64::from(c) << (level - point.level));
    let sign = |c: i64| if c < 0 { -1 } else { 1 };
    // The upper half maps to the diamond |u| + |v| <= side, the lower half folds out to the
    // corners of the square [-side, side]².
    let (u, v) = if k >= 0 {
        (i, j)
    } else {
        (sign(i) * (side - j.abs()), sign(j) * (side - i.abs()))
    };
    hilbert(4 << level, (u + side) as u64, (v + side) as u64)
}

/// The Hilbert curve's index of cell `(x, y)` in an `n × n` grid (`n` a power of two).
fn hilbert(n: u64, mut x: u64, mut y: u64) -> u64 {
    let mut d = 0;
    let mut s = n / 2;
    while s > 0 {
        let rx = u64::from(x & s != 0);
        let ry = u64::from(y & s != 0);
        d += s * s * ((3 * rx) ^ ry);
        if ry == 0 {
            if rx == 1 {
                x = n - 1 - x;
                y = n - 1 - y;
            }
            std::mem::swap(&mut x, &mut y);
        }
        s /= 2;
    }
    d
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sphere::{MAX_LEVEL, parents};

    #[test]
    fn shards_own_every_view_once_in_balanced_shares() {
        for level in [0, 3, 5] {
            for count in [1, 2, 3, 4, 7, 100] {
                let total = view_count(level);
                let mut owner = vec![u32::MAX; total as usize];
                for index in 0..count {
                    let views = Shard { index, count }.views(level);
                    let fair = total / count;
                    assert!(
                        views.len() as u32 == fair || views.len() as u32 == fair + 1,
                        "level {level}, {index}/{count}: {} views",
                        views.len()
                    );
                    assert!(views.is_sorted());
                    for v in views {
                        assert_eq!(owner[v as usize], u32::MAX, "view {v} owned twice");
                        owner[v as usize] = index;
                    }
                }
                assert!(owner.iter().all(|&o| o != u32::MAX));
            }
        }
    }

    /// The shares are compact: of the views of four shards, at most a tenth of the parents
    /// (as the sampler seeds from them) lie outside the shard at level 5.
    #[test]
    fn most_parents_lie_in_the_same_shard() {
        let level = 5;
        let count = 4;
        let mut owner = vec![0; view_count(level) as usize];
        for index in 0..count {
            for v in (Shard { index, count }).views(level) {
                owner[v as usize] = index;
            }
        }
        let (mut outside, mut all) = (0, 0);
        for v in 0..view_count(level) {
            for p in parents(v).into_iter().flatten() {
                all += 1;
                outside += u32::from(owner[p as usize] != owner[v as usize]);
            }
        }
        assert!(
            outside * 10 <= all,
            "{outside} of {all} parents in another shard"
        );
    }

    #[test]
    fn every_level_has_a_key_for_every_view() {
        let total = view_count(MAX_LEVEL);
        let mut keys: Vec<u64> = (0..total).map(|v| curve_key(v, MAX_LEVEL)).collect();
        keys.sort_unstable();
        keys.dedup();
        // Distinct lattice points map to distinct cells (the fold is one to one).
        assert_eq!(keys.len() as u32, total);
    }

    #[test]
    fn shards_parse_and_come_from_the_scheduler() {
        assert_eq!(Shard::parse("2/4"), Ok(Shard { index: 2, count: 4 }));
        for bad in ["4/4", "1", "a/4", "0/0", "-1/4", "1/4/2", "0/65537"] {
            assert!(Shard::parse(bad).is_err(), "{bad}");
        }
        let env = |pairs: &'static [(&'static str, &'static str)]| {
            move |name: &str| {
                pairs
                    .iter()
                    .find(|(n, _)| *n == name)
                    .map(|(_, v)| v.to_string())
            }
        };
        let slurm = Shard::from_env(env(&[
            ("SLURM_ARRAY_TASK_ID", "3"),
            ("SLURM_ARRAY_TASK_COUNT", "4"),
        ]));
        assert_eq!(slurm, Ok(Shard { index: 3, count: 4 }));
        let slurm = Shard::from_env(env(&[
            ("SLURM_ARRAY_TASK_ID", "5"),
            ("SLURM_ARRAY_TASK_MIN", "4"),
            ("SLURM_ARRAY_TASK_MAX", "7"),
        ]));
        assert_eq!(slurm, Ok(Shard { index: 1, count: 4 }));
        let stepped = Shard::from_env(env(&[
            ("SLURM_ARRAY_TASK_ID", "2"),
            ("SLURM_ARRAY_TASK_COUNT", "4"),
            ("SLURM_ARRAY_TASK_STEP", "2"),
        ]));
        assert!(stepped.unwrap_err().0.contains("step 2"));
        let k8s = Shard::from_env(env(&[
            ("JOB_COMPLETION_INDEX", "0"),
            ("PATCHVIS_SHARD_COUNT", "8"),
        ]));
        assert_eq!(k8s, Ok(Shard { index: 0, count: 8 }));
        let err = Shard::from_env(env(&[("JOB_COMPLETION_INDEX", "0")])).unwrap_err();
        assert!(err.0.contains(SHARD_COUNT_ENV), "{}", err.0);
        let err = Shard::from_env(env(&[])).unwrap_err();
        assert!(err.0.contains("SLURM_ARRAY_TASK_ID"), "{}", err.0);
    }
}
