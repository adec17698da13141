//! Chain-latency statistics in constant memory, with `hdrhistogram`.
//!
//! The driver used to keep every latency sample (8 bytes per command, growing the heap
//! by ~0.2–0.5 MiB per minute at 1 kHz until a 4 h cap) to sort them at exit; then a
//! hand-written log-linear histogram. This is HdrHistogram itself: 2 significant digits
//! (128 sub-buckets per power of two, so every quantile is within 1/128 = 0.8 % of a
//! recorded value) from 1 ns to 2^41 ns ≈ 37 min (longer values count as 37 min).
//! Allocated once; `record` is O(1) without allocation. The exact minimum and maximum are
//! kept besides.

/// Largest value tracked [ns]: 2^41 ≈ 37 min.
const MAX_NS: u64 = 1 << 41;

/// A latency histogram [ns].
#[derive(Clone)]
pub struct Histogram {
    h: hdrhistogram::Histogram<u64>,
    min: u64,
    max: u64,
}

impl Default for Histogram {
    fn default() -> Self {
        let h = hdrhistogram::Histogram::new_with_bounds(1, MAX_NS, 2).expect("valid fixed histogram bounds");
        Self { h, min: u64::MAX, max: 0 }
    }
}

impl Histogram {
    /// Record one latency [ns]; negative values (clock steps) count as 0.
    pub fn record(&mut self, ns: i64) {
        let v = ns.max(0) as u64;
        self.h.saturating_record(v);
        self.min = self.min.min(v);
        self.max = self.max.max(v);
    }

    pub fn len(&self) -> u64 {
        self.h.len()
    }

    pub fn max_ns(&self) -> Option<u64> {
        (self.len() > 0).then_some(self.max)
    }

    /// The `f`-quantile (0..=1): HdrHistogram's rank rule (the value at rank ⌈f n⌉, at
    /// least 1), reported as the middle of that value's bucket, clamped to [min, max].
    pub fn quantile_ns(&self, f: f64) -> Option<f64> {
        if self.len() == 0 {
            return None;
        }
        let v = self.h.median_equivalent(self.h.value_at_quantile(f.clamp(0.0, 1.0)));
        Some((v as f64).clamp(self.min as f64, self.max as f64))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantiles_are_within_one_percent_of_the_exact_ones() {
        // 200k log-uniform latencies from 20 µs to 200 ms (fixed seed).
        let mut rng = naic_core::rng::Rng::seed(0x9E37_79B9_7F4A_7C15);
        let mut v = Vec::new();
        let mut h = Histogram::default();
        for _ in 0..200_000 {
            let u = rng.uniform();
            let ns = (20e3 * (1e4f64).powf(u)) as i64;
            v.push(ns);
            h.record(ns);
        }
        v.sort_unstable();
        for f in [0.0, 0.01, 0.5, 0.9, 0.99, 0.999, 1.0] {
            let exact = v[((v.len() - 1) as f64 * f).round() as usize] as f64;
            let got = h.quantile_ns(f).unwrap();
            assert!((got - exact).abs() <= exact / 100.0, "q{f}: {got} vs exact {exact}");
        }
        assert_eq!(h.max_ns(), Some(*v.last().unwrap() as u64));
        assert_eq!(h.len(), 200_000);
    }

    #[test]
    fn empty_small_and_negative_values() {
        let mut h = Histogram::default();
        assert_eq!(h.quantile_ns(0.5), None);
        assert_eq!(h.max_ns(), None);
        h.record(-5);
        h.record(3);
        h.record(40);
        assert_eq!(h.quantile_ns(0.0), Some(0.0));
        assert_eq!(h.quantile_ns(0.5), Some(3.0));
        assert_eq!(h.quantile_ns(1.0), Some(40.0));
    }
}
