//! Summary statistics of a series of frame measurements.

/// Percentiles (nearest rank), mean, standard deviation and extremes.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Summary {
    /// Samples.
    pub n: usize,
    /// Arithmetic mean.
    pub mean: f64,
    /// Population standard deviation.
    pub std: f64,
    /// Median.
    pub p50: f64,
    /// 95th percentile.
    pub p95: f64,
    /// 99th percentile.
    pub p99: f64,
    /// Largest sample.
    pub max: f64,
}

impl Summary {
    /// Summarizes `v` (unsorted; non-finite samples are ignored).
    pub fn of(v: &[f64]) -> Summary {
        let mut s: Vec<f64> = v.iter().copied().filter(|x| x.is_finite()).collect();
        if s.is_empty() {
            return Summary::default();
        }
        s.sort_by(f64::total_cmp);
        let n = s.len();
        let mean = s.iter().sum::<f64>() / n as f64;
        let var = s.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / n as f64;
        Summary {
            n,
            mean,
            std: var.sqrt(),
            p50: nearest_rank(&s, 0.50),
            p95: nearest_rank(&s, 0.95),
            p99: nearest_rank(&s, 0.99),
            max: s[n - 1],
        }
    }
}

/// The `q`-quantile of sorted, non-empty `s` by the nearest-rank method:
/// the smallest sample with at least `q·n` samples at or below it.
pub fn nearest_rank(s: &[f64], q: f64) -> f64 {
    let rank = (q * s.len() as f64).ceil() as usize;
    s[rank.clamp(1, s.len()) - 1]
}

/// Counts of `v` in `bins` equal-width bins over `[lo, hi]` (samples outside
/// are clamped into the end bins).
pub fn histogram(v: &[f64], lo: f64, hi: f64, bins: usize) -> Vec<u32> {
    let bins = bins.max(1);
    let mut out = vec![0u32; bins];
    let width = (hi - lo).max(f64::MIN_POSITIVE);
    for &x in v.iter().filter(|x| x.is_finite()) {
        let i = ((x - lo) / width * bins as f64).floor();
        out[(i.max(0.0) as usize).min(bins - 1)] += 1;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn known_series() {
        let s = Summary::of(&[4.0, 1.0, 3.0, 2.0]);
        assert_eq!((s.p50, s.p95, s.max, s.mean), (2.0, 4.0, 4.0, 2.5));
        assert!((s.std - 1.25f64.sqrt()).abs() < 1e-12);
        assert_eq!(Summary::of(&[]), Summary::default());
        assert_eq!(Summary::of(&[f64::NAN, 5.0]).n, 1);
    }

    proptest! {
        #[test]
        fn percentiles_match_brute_force(v in prop::collection::vec(-1e6f64..1e6, 1..200), q in 0.01f64..1.0) {
            let mut s = v.clone();
            s.sort_by(f64::total_cmp);
            let got = nearest_rank(&s, q);
            // Brute force: the smallest sample x with count(<= x) >= q·n.
            let want = s.iter().copied().find(|&x| {
                s.iter().filter(|&&y| y <= x).count() as f64 >= q * s.len() as f64
            }).unwrap();
            prop_assert_eq!(got, want);
        }

        #[test]
        fn histogram_counts_every_sample(v in prop::collection::vec(0f64..10.0, 0..100), bins in 1usize..20) {
            let h = histogram(&v, 0.0, 10.0, bins);
            prop_assert_eq!(h.iter().sum::<u32>() as usize, v.len());
        }
    }
}
