//! Exact reduction of the round-trip phase `2 pi f 2r / v` (docs/model.md §6). With
//! `f = k fs / n`, the phase in cycles is `k q` with `q = fs 2r / (n v)`. `q` is kept as a
//! double-double and `k q` reduced modulo 1 with error-free products, so the phase is accurate
//! to about 1e-16 cycles whatever its size.

#[inline(always)]
fn two_prod(a: f64, b: f64) -> (f64, f64) {
    let p = a * b;
    (p, a.mul_add(b, -p))
}

/// Round-trip delay in cycles per rFFT bin, `q = fs 2r / (n v)`, as `hi + lo`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CyclesPerBin {
    pub hi: f64,
    pub lo: f64,
}

impl CyclesPerBin {
    #[inline(always)]
    pub fn new(range: f64, fs: f64, n: usize, sound_speed: f64) -> Self {
        let (h, l) = two_prod(fs, 2.0 * range);
        let (dh, dl) = two_prod(n as f64, sound_speed);
        // (1/dh rather than two divisions: a caller's loop computes it once; q1 may then be an
        // ulp or two from h/dh, which the exact remainder below takes up)
        let inv = 1.0 / dh;
        let q1 = h * inv;
        let (p, e) = two_prod(q1, dh);
        let rem = ((h - p) - e) + l - q1 * dl;
        CyclesPerBin {
            hi: q1,
            lo: rem * inv,
        }
    }

    /// `k q` modulo 1, in [-0.5, 0.5].
    #[inline(always)]
    pub fn frac_at(&self, k: f64) -> f64 {
        let (p, e) = two_prod(k, self.hi);
        let t = (p - p.round()) + (e + k * self.lo);
        t - t.round()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matches_direct_product_for_small_phases() {
        let q = CyclesPerBin::new(1.234, 400e3, 24000, 340.0);
        let direct = 400e3 * 2.0 * 1.234 / (24000.0 * 340.0);
        assert!((q.hi + q.lo - direct).abs() <= 2e-16 * direct);
        let k = 3.0;
        let want = k * direct;
        assert!((q.frac_at(k) - (want - want.round())).abs() < 1e-15);
    }

    #[test]
    fn frac_at_matches_exact_rationals_for_random_ranges() {
        // r = m / 2^20 m (up to 16 km), so that k fs 2r / (n v) is a ratio of integers
        let mut u = crate::test_util::uniforms(17);
        let mut worst: f64 = 0.0;
        for _ in 0..20_000 {
            let m = (u() * 2f64.powi(34)) as u64 + 1;
            let k = (u() * 4800.0) as u64 + 1;
            let q = CyclesPerBin::new(m as f64 / 2f64.powi(20), 400e3, 24000, 340.0);
            let num = k as u128 * 400_000 * 2 * m as u128;
            let den = 24_000u128 * 340 * (1 << 20);
            let frac = (num % den) as f64 / den as f64;
            let want = if frac > 0.5 { frac - 1.0 } else { frac };
            let d = (q.frac_at(k as f64) - want).abs();
            worst = worst.max(d.min(1.0 - d));
        }
        assert!(worst <= 3e-16, "{worst:e}");
    }

    #[test]
    fn stays_exact_for_huge_phases() {
        // r = 1e4 m: 7e7 cycles at bin 4800. Compare with an exact rational evaluation:
        // fs 2r / (n v) with all terms exactly representable as integers / 2^m.
        let q = CyclesPerBin::new(10_000.0, 400e3, 24000, 340.0);
        // exact: 4800 * 400000 * 20000 / (24000 * 340) = 3.84e13 / 8.16e6 = 4705882.352941176...
        let k = 4800.0;
        let num: u128 = 4800 * 400_000 * 20_000;
        let den: u128 = 24_000 * 340;
        let frac = (num % den) as f64 / den as f64; // 0.352941...
        let want = if frac > 0.5 { frac - 1.0 } else { frac };
        assert!(
            (q.frac_at(k) - want).abs() < 1e-15,
            "{} vs {}",
            q.frac_at(k),
            want
        );
    }
}
