//! Statistics helpers shared by the loops (`targets`) and the bench: nearest-rank summaries and constant-memory histograms.

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

/// Quantiles of arbitrarily long series of durations in milliseconds in
/// bounded memory (a run of days at headset rates), through the
/// `hdrhistogram` crate (Gil Tene's HdrHistogram): values are counted in
/// nanoseconds from 1 ns to 1000 s at four significant digits, so a
/// reported quantile is within 0.01 % of the exact nearest-rank value.
#[derive(Clone, Debug)]
pub struct FrameHistogram {
    h: hdrhistogram::Histogram<u64>,
}

/// The largest duration counted exactly, ns (1000 s; longer ones are
/// counted as this).
const HIST_MAX_NS: u64 = 1_000_000_000_000;

impl Default for FrameHistogram {
    fn default() -> Self {
        FrameHistogram {
            h: hdrhistogram::Histogram::new_with_bounds(1, HIST_MAX_NS, 4)
                .expect("valid fixed bounds"),
        }
    }
}

impl FrameHistogram {
    /// Counts `v` milliseconds (non-finite and negative values are
    /// ignored; values above 1000 s count as 1000 s).
    pub fn record(&mut self, v: f64) {
        if !v.is_finite() || v < 0.0 {
            return;
        }
        let ns = (v * 1e6).round().min(HIST_MAX_NS as f64) as u64;
        self.h.saturating_record(ns);
    }

    /// Samples counted.
    pub fn len(&self) -> u64 {
        self.h.len()
    }

    /// Whether nothing was counted.
    pub fn is_empty(&self) -> bool {
        self.h.is_empty()
    }

    /// The `q`-quantile in milliseconds (0 when empty).
    pub fn quantile(&self, q: f64) -> f64 {
        if self.h.is_empty() {
            return 0.0;
        }
        self.h.value_at_quantile(q.clamp(0.0, 1.0)) as f64 * 1e-6
    }
}

#[cfg(test)]
mod frame_histogram_tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #[test]
        fn quantiles_are_within_a_thousandth(v in prop::collection::vec(0.01f64..5000.0, 1..300), q in 0.01f64..1.0) {
            let mut h = FrameHistogram::default();
            for &x in &v {
                h.record(x);
            }
            let mut s = v.clone();
            s.sort_by(f64::total_cmp);
            let exact = nearest_rank(&s, q);
            let got = h.quantile(q);
            prop_assert!((got / exact - 1.0).abs() < 0.001, "{got} vs {exact}");
        }
    }

    #[test]
    fn close_medians_stay_apart() {
        // Two series whose medians differ by 0.4 % (a log histogram of
        // 1 % bins reported both as one value).
        let (mut a, mut b) = (FrameHistogram::default(), FrameHistogram::default());
        for i in 0..1001 {
            let d = (i as f64 - 500.0) * 1e-3;
            a.record(515.95 + d);
            b.record(513.77 + d);
        }
        assert!(
            (a.quantile(0.5) / 515.95 - 1.0).abs() < 1e-3,
            "{}",
            a.quantile(0.5)
        );
        assert!(
            (b.quantile(0.5) / 513.77 - 1.0).abs() < 1e-3,
            "{}",
            b.quantile(0.5)
        );
        assert_eq!(FrameHistogram::default().quantile(0.5), 0.0);
        assert_eq!(a.len(), 1001);
    }
}

/// Median and 95th percentile of a series.
#[derive(Clone, Copy, Debug, Default, serde::Serialize)]
pub struct Percentiles {
    /// Median.
    pub median: f64,
    /// 95th percentile (nearest rank).
    pub p95: f64,
}

impl Percentiles {
    /// Of `v` (unsorted; nearest rank, as [`Summary`]).
    pub fn of(v: &[f64]) -> Percentiles {
        let s = Summary::of(v);
        Percentiles {
            median: s.p50,
            p95: s.p95,
        }
    }
}
