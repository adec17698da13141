//! Chain-latency statistics in constant memory.
//!
//! The driver used to keep every latency sample (8 bytes per command, growing the heap
//! by ~0.2–0.5 MiB per minute at 1 kHz until a 4 h cap) to sort them at exit. This is a
//! log-linear histogram instead (the idea of HdrHistogram): values below 64 ns exactly,
//! above that 64 sub-buckets per power of two, so every quantile is within 1/128 (0.8 %)
//! of a recorded value. Fixed size, allocated once, `record` is O(1) without allocation;
//! the exact minimum and maximum are kept besides.

/// Sub-buckets per power of two (2^6).
const SUB_BITS: u32 = 6;
const SUB: usize = 1 << SUB_BITS;
/// Largest exponent covered: 2^41 ns ≈ 37 min; longer values land in the last bucket.
const MAX_EXP: usize = 41;
/// Number of buckets.
pub const BUCKETS: usize = SUB + (MAX_EXP - SUB_BITS as usize + 1) * SUB;

/// A latency histogram [ns].
#[derive(Clone)]
pub struct Histogram {
    counts: [u64; BUCKETS],
    n: u64,
    min: u64,
    max: u64,
}

impl Default for Histogram {
    fn default() -> Self {
        Self { counts: [0; BUCKETS], n: 0, min: u64::MAX, max: 0 }
    }
}

fn bucket(v: u64) -> usize {
    if v < SUB as u64 {
        return v as usize;
    }
    let e = (63 - v.leading_zeros()).min(MAX_EXP as u32); // floor(log2 v) >= SUB_BITS
    let v = v.min((1u64 << (MAX_EXP + 1)) - 1);
    let m = ((v >> (e - SUB_BITS)) as usize) & (SUB - 1);
    SUB + (e - SUB_BITS) as usize * SUB + m
}

/// The value range `[lo, hi)` of bucket `i`.
fn bounds(i: usize) -> (u64, u64) {
    if i < SUB {
        return (i as u64, i as u64 + 1);
    }
    let e = ((i - SUB) / SUB) as u32 + SUB_BITS;
    let m = ((i - SUB) % SUB) as u64;
    let w = 1u64 << (e - SUB_BITS);
    let lo = (1u64 << e) + m * w;
    (lo, lo + w)
}

impl Histogram {
    /// Record one latency [ns]; negative values (clock steps) count as 0.
    pub fn record(&mut self, ns: i64) {
        let v = ns.max(0) as u64;
        self.counts[bucket(v)] += 1;
        self.n += 1;
        self.min = self.min.min(v);
        self.max = self.max.max(v);
    }

    pub fn len(&self) -> u64 {
        self.n
    }

    pub fn max_ns(&self) -> Option<u64> {
        (self.n > 0).then_some(self.max)
    }

    /// The `f`-quantile (0..=1) with the rank rule of a sorted array's index
    /// `round((n − 1) f)`: the middle of that sample's bucket, clamped to [min, max].
    pub fn quantile_ns(&self, f: f64) -> Option<f64> {
        if self.n == 0 {
            return None;
        }
        let rank = ((self.n - 1) as f64 * f.clamp(0.0, 1.0)).round() as u64;
        let mut seen = 0u64;
        for (i, &c) in self.counts.iter().enumerate() {
            seen += c;
            if seen > rank {
                let (lo, hi) = bounds(i);
                let mid = if hi - lo == 1 { lo as f64 } else { (lo + hi) as f64 / 2.0 };
                return Some(mid.clamp(self.min as f64, self.max as f64));
            }
        }
        Some(self.max as f64)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn buckets_tile_the_range_without_gaps() {
        let mut next = 0;
        for i in 0..BUCKETS {
            let (lo, hi) = bounds(i);
            assert_eq!(lo, next, "bucket {i}");
            assert!(hi > lo);
            assert_eq!(bucket(lo), i);
            assert_eq!(bucket(hi - 1), i);
            next = hi;
        }
        assert_eq!(bucket(u64::MAX), BUCKETS - 1);
    }

    #[test]
    fn quantiles_are_within_one_percent_of_the_exact_ones() {
        // 200k log-uniform latencies from 20 µs to 200 ms (xorshift, fixed seed).
        let mut x = 0x9E37_79B9_7F4A_7C15u64;
        let mut v = Vec::new();
        let mut h = Histogram::default();
        for _ in 0..200_000 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            let u = (x >> 11) as f64 / (1u64 << 53) as f64;
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
