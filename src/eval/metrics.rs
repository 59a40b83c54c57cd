//! Aggregate statistics and image metrics for the evaluation: mean / 95th and 99th percentile /
//! maximum of a per-view quantity, and PSNR.
//!
//! The percentiles are nearest-rank ones (the smallest value with at least 95 % or 99 % of the
//! samples at or below it), so they are always measured values — with 200 views p95 is the
//! 190th smallest and p99 the 198th. Cost: one sort of the samples.

/// Mean, 95th and 99th percentile and maximum of a set of samples.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Summary {
    /// Arithmetic mean (0 for no samples).
    pub mean: f64,
    /// Nearest-rank 95th percentile (0 for no samples).
    pub p95: f64,
    /// Nearest-rank 99th percentile (0 for no samples).
    pub p99: f64,
    /// Largest sample (0 for no samples).
    pub max: f64,
    /// Smallest sample (0 for no samples).
    pub min: f64,
}

/// The smallest of `sorted` (ascending, not empty) with at least the fraction `p` of the
/// samples at or below it: rank `ceil(p·n)`, 1-based. The small epsilon keeps 0.95·100 =
/// 95.000…01 at 95.
fn nearest_rank(sorted: &[f64], p: f64) -> f64 {
    let n = sorted.len();
    let rank = ((p * n as f64) - 1e-9).ceil().max(1.0) as usize;
    sorted[rank.min(n) - 1]
}

impl Summary {
    /// Summarises `samples`, which must all be finite (caller contract).
    pub fn of(samples: impl IntoIterator<Item = f64>) -> Summary {
        let mut sorted: Vec<f64> = samples.into_iter().collect();
        assert!(
            sorted.iter().all(|v| v.is_finite()),
            "summaries take finite samples only"
        );
        if sorted.is_empty() {
            return Summary {
                mean: 0.0,
                p95: 0.0,
                p99: 0.0,
                max: 0.0,
                min: 0.0,
            };
        }
        sorted.sort_by(f64::total_cmp);
        let n = sorted.len();
        Summary {
            mean: sorted.iter().sum::<f64>() / n as f64,
            p95: nearest_rank(&sorted, 0.95),
            p99: nearest_rank(&sorted, 0.99),
            max: sorted[n - 1],
            min: sorted[0],
        }
    }
}

/// Largest value of an 8-bit channel, the peak of PSNR.
const PEAK: f64 = 255.0;

/// Peak signal-to-noise ratio in dB of 8-bit images whose mean squared channel error is `mse`:
/// `10 · log10(255² / mse)`. Identical images (`mse == 0`) give `+∞`.
pub fn psnr(mse: f64) -> f64 {
    assert!(
        mse >= 0.0 && mse.is_finite(),
        "mean squared error must be finite and non-negative, got {mse}"
    );
    if mse == 0.0 {
        f64::INFINITY
    } else {
        10.0 * (PEAK * PEAK / mse).log10()
    }
}

/// Mean squared error per channel between two equally sized 8-bit images.
pub fn mse(a: &[u8], b: &[u8]) -> f64 {
    assert_eq!(a.len(), b.len(), "images to compare differ in size");
    if a.is_empty() {
        return 0.0;
    }
    let sum: u64 = a
        .iter()
        .zip(b)
        .map(|(&x, &y)| {
            let d = u64::from(x.abs_diff(y));
            d * d
        })
        .sum();
    sum as f64 / a.len() as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn p95_is_the_nearest_rank_value() {
        let s = Summary::of((1..=100).map(f64::from));
        assert_eq!((s.mean, s.p95, s.max, s.min), (50.5, 95.0, 100.0, 1.0));
        assert_eq!(s.p99, 99.0);
        // 200 samples: p99 is the 198th smallest.
        assert_eq!(Summary::of((1..=200).map(f64::from)).p99, 198.0);
        assert_eq!(Summary::of([7.0]).p99, 7.0);
        // 20 samples: rank ceil(19) = 19.
        assert_eq!(Summary::of((1..=20).map(f64::from)).p95, 19.0);
        // 200 views: the 190th smallest, whatever the input order.
        let reversed = Summary::of((0..200).rev().map(f64::from));
        assert_eq!(reversed.p95, 189.0);
        // Few samples: the maximum.
        assert_eq!(Summary::of([3.0, 1.0, 2.0]).p95, 3.0);
        assert_eq!(Summary::of([7.0]).p95, 7.0);
        assert_eq!(Summary::of([]).mean, 0.0);
    }

    #[test]
    fn psnr_of_known_errors() {
        assert_eq!(psnr(0.0), f64::INFINITY);
        assert!((psnr(PEAK * PEAK) - 0.0).abs() < 1e-12);
        // 30 dB ⇔ mse = 255² / 1000.
        assert!((psnr(65.025) - 30.0).abs() < 1e-9);
        assert!((psnr(1.0) - 48.130_803_608_679_1).abs() < 1e-9);
    }

    #[test]
    fn mse_counts_every_channel() {
        assert_eq!(mse(&[0, 0, 0, 0], &[0, 0, 0, 0]), 0.0);
        // One channel off by 10 in four: 100 / 4.
        assert_eq!(mse(&[10, 0, 0, 0], &[0, 0, 0, 0]), 25.0);
        assert_eq!(mse(&[0, 255], &[255, 0]), 65025.0);
        let a = [0u8, 255, 0, 255, 0, 255];
        let b = [255u8, 255, 255, 255, 255, 255];
        assert!((psnr(mse(&a, &b)) - 10.0 * 2f64.log10()).abs() < 1e-12);
    }
}
