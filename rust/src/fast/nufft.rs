//! A 1-D type-1 non-uniform FFT with many channels sharing the same points:
//! `U_q(k) = sum_i s_iq exp(-2 pi j k x_i)`, `k = -K/2 .. K - 1 - K/2`, points `x_i` in [0, 1).
//!
//! The method of FINUFFT (Barnett, Magland & af Klinteberg 2019): strengths are spread onto an
//! oversampled periodic grid (`sigma = 2`) with the "exponential of semicircle" kernel
//! `phi(z) = exp(beta (sqrt(1 - z^2) - 1))`, `|z| <= 1`, of width `w` grid points; one FFT per
//! channel; then each mode is divided by the kernel's Fourier transform, computed by
//! Gauss-Legendre quadrature. Width and shape come from the tolerance:
//! `w = ceil(log10(1/eps)) + 1` and `beta = 2.30 w`. The kernel weights of a point are computed
//! once and shared by all channels.

use crate::error::{invalid, Result};
use crate::math::vmath::exp_nonpos;
use rustfft::num_complex::Complex64;
use rustfft::{Fft, FftPlanner};
use std::f64::consts::PI;
use std::sync::Arc;

thread_local! {
    /// The FFTs' scratch space, per thread.
    static FFT_SCRATCH: std::cell::RefCell<Vec<Complex64>> = const { std::cell::RefCell::new(Vec::new()) };
}

/// Widest kernel (reached for eps <= 1e-15).
pub const MAX_W: usize = 16;

/// Gauss-Legendre nodes and weights on [-1, 1] (Newton iteration on P_n).
pub fn gauss_legendre(n: usize) -> (Vec<f64>, Vec<f64>) {
    let mut x = vec![0.0; n];
    let mut w = vec![0.0; n];
    for i in 0..n.div_ceil(2) {
        let mut z = (PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
        let mut dp = 0.0;
        for _ in 0..100 {
            let (mut p0, mut p1) = (1.0, z);
            for k in 2..=n {
                let p2 = ((2 * k - 1) as f64 * z * p1 - (k - 1) as f64 * p0) / k as f64;
                p0 = p1;
                p1 = p2;
            }
            // p1 = P_n(z), p0 = P_{n-1}(z)
            dp = n as f64 * (z * p1 - p0) / (z * z - 1.0);
            let dz = p1 / dp;
            z -= dz;
            if dz.abs() < 1e-16 {
                break;
            }
        }
        x[i] = -z;
        x[n - 1 - i] = z;
        w[i] = 2.0 / ((1.0 - z * z) * dp * dp);
        w[n - 1 - i] = w[i];
    }
    (x, w)
}

/// The ES kernel as piecewise polynomials. A point at grid coordinate `xs` has its first grid
/// point at `l0 = ceil(xs - w/2)`, and `u = l0 - (xs - w/2)` in [0, 1); grid point `l0 + j`
/// gets the weight `phi((j + u - w/2) 2 / w)`. For each `j` that is a smooth function of `u`,
/// interpolated at `w + 2` Chebyshev nodes (degree `w + 1`) and stored as monomial
/// coefficients in `u`: `coef[d][j]`. (The single-point worst error of a type-1 transform at
/// 1201 modes is the same to three digits as with FINUFFT's degree `w + 3` for w = 4 ... 13,
/// e.g. 1.07e-7 at w = 8: the kernel's own truncation dominates; degree `w - 1` adds 40% at
/// w = 4. Two Horner steps fewer per leaf.)
fn kernel_polynomials(w: usize, beta: f64) -> Vec<[f64; MAX_W]> {
    let deg = w + 1;
    let n = deg + 1;
    // Chebyshev nodes on [0, 1]
    let us: Vec<f64> = (0..n)
        .map(|k| 0.5 + 0.5 * ((2 * k + 1) as f64 * PI / (2 * n) as f64).cos())
        .collect();
    let phi = |z: f64| {
        if z.abs() <= 1.0 {
            (beta * ((1.0 - z * z).sqrt() - 1.0)).exp()
        } else {
            0.0
        }
    };
    // Solve the Vandermonde system for the monomial coefficients on [0, 1] per interval j.
    let mut coef = vec![[0.0f64; MAX_W]; n];
    for j in 0..w {
        // weight of grid point l0 + j for a point whose offset from l0 is -u (u = l0 - xs in [0, 1))
        let vals: Vec<f64> = us
            .iter()
            .map(|&u| phi((j as f64 + u - w as f64 / 2.0) * 2.0 / w as f64))
            .collect();
        let c = solve_vandermonde(&us, &vals);
        for (row, &cd) in coef.iter_mut().zip(&c) {
            row[j] = cd;
        }
    }
    coef
}

/// [`Type1Plan::mirror`] from the monomial coefficients in `u` of an eight-tap kernel: each
/// of taps 0-3 shifted to `v = u - 1/2` (exact Taylor shift, `binomial(d, i) (1/2)^(d-i)`)
/// and split into even and odd powers.
fn mirror_polynomials(coef: &[[f64; MAX_W]]) -> Vec<[f64; 8]> {
    let n = coef.len();
    let mut rows = vec![[0.0f64; 8]; n.div_ceil(2)];
    for j in 0..4 {
        // c'_i = sum_d coef[d][j] binom(d, i) 2^-(d - i)
        for i in 0..n {
            let mut acc = 0.0;
            for (d, row) in coef.iter().enumerate().skip(i) {
                let mut b = 1.0;
                for t in 0..i {
                    b = b * (d - t) as f64 / (t + 1) as f64;
                }
                acc += row[j] * b * 0.5f64.powi((d - i) as i32);
            }
            rows[i / 2][j + 4 * (i % 2)] = acc;
        }
    }
    rows
}

/// Monomial coefficients of the polynomial through `(x_k, y_k)` (Newton divided differences;
/// well conditioned enough on [0, 1] for the degrees used here).
fn solve_vandermonde(x: &[f64], y: &[f64]) -> Vec<f64> {
    let n = x.len();
    let mut dd = y.to_vec();
    for k in 1..n {
        for i in (k..n).rev() {
            dd[i] = (dd[i] - dd[i - 1]) / (x[i] - x[i - k]);
        }
    }
    // expand the Newton form into monomials
    let mut c = vec![0.0; n];
    for k in (0..n).rev() {
        // c = c * (t - x_k) + dd_k
        let mut next = vec![0.0; n];
        for d in 0..n {
            if d + 1 < n {
                next[d + 1] += c[d];
            }
            next[d] -= c[d] * x[k];
        }
        next[0] += dd[k];
        c = next;
    }
    c
}

/// Smallest `n >= min` whose prime factors are 2, 3 and 5 (fast FFT sizes), and even.
pub fn fft_size(min: usize) -> usize {
    let mut n = min.max(2);
    loop {
        let mut m = n;
        for p in [2, 3, 5] {
            while m.is_multiple_of(p) {
                m /= p;
            }
        }
        if m == 1 && n.is_multiple_of(2) {
            return n;
        }
        n += 1;
    }
}

/// A type-1 plan for `modes` output modes at tolerance `eps`.
pub struct Type1Plan {
    pub modes: usize,
    /// Oversampled grid size (even, >= 2 modes, 2-3-5 smooth).
    pub nf: usize,
    /// Kernel width in grid points, and its shape parameter.
    pub w: usize,
    pub beta: f64,
    /// Padding on each side of a spread grid (indices may run past the ends before folding);
    /// [`MAX_W`], so that fixed-width spreading of up to `MAX_W` points always fits.
    pub pad: usize,
    /// `1 / (nf Phi(k))` for the modes `k = -modes/2 ..`.
    correction: Vec<f64>,
    /// Piecewise-polynomial kernel (as FINUFFT evaluates it): `weight_j(u) =
    /// sum_d horner[d][j] u^d` for the point's offset `u` in [0, 1) from its first grid point.
    pub horner: Vec<[f64; MAX_W]>,
    /// For `w = 8` (else empty): the same polynomials in `v = u - 1/2`, split by parity, for
    /// the four mirror pairs of taps (`weight_(7-j)(u) = weight_j(1 - u)`, as the kernel is
    /// even): row `i` holds `[E_0 .. E_3, O_0 .. O_3]`, the coefficients of `v^(2i)` of
    /// `weight_j = E_j(v^2) + v O_j(v^2)`. Half the Horner steps of `horner`.
    pub mirror: Vec<[f64; 8]>,
    fft: Arc<dyn Fft<f64>>,
}

impl Type1Plan {
    pub fn new(modes: usize, eps: f64) -> Result<Self> {
        if modes == 0 {
            return invalid("a NUFFT needs at least one mode");
        }
        if !(eps.is_finite() && eps > 0.0 && eps < 1.0) {
            return invalid(format!("NUFFT tolerance must be in (0, 1), got {eps}"));
        }
        let w = ((1.0 / eps).log10().ceil() as usize + 1).clamp(2, MAX_W);
        let beta = 2.30 * w as f64;
        let nf = fft_size((2 * modes).max(2 * w));
        // Phi(k) = (w / (2 nf)) int_{-1}^{1} phi(z) cos(pi k w z / nf) dz, with z = sin(theta)
        // so that the integrand is smooth at the ends.
        let (gx, gw) = gauss_legendre(2 * w + 40);
        let half = modes / 2;
        let correction = (0..modes)
            .map(|i| {
                let k = i as f64 - half as f64;
                let mut s = 0.0;
                for (&u, &wt) in gx.iter().zip(&gw) {
                    let th = u * PI / 2.0;
                    let z = th.sin();
                    let phi = (beta * (th.cos() - 1.0)).exp();
                    s += wt * phi * (PI * k * w as f64 * z / nf as f64).cos() * th.cos();
                }
                let integral = s * PI / 2.0;
                let phi_hat = w as f64 / (2.0 * nf as f64) * integral;
                1.0 / (nf as f64 * phi_hat)
            })
            .collect();
        let fft = FftPlanner::<f64>::new().plan_fft_forward(nf);
        let horner = kernel_polynomials(w, beta);
        let mirror = if w == 8 {
            mirror_polynomials(&horner)
        } else {
            Vec::new()
        };
        Ok(Type1Plan {
            modes,
            nf,
            w,
            beta,
            pad: MAX_W,
            correction,
            horner,
            mirror,
            fft,
        })
    }

    /// Length of one channel's spread grid (with padding).
    pub fn grid_len(&self) -> usize {
        self.nf + 2 * self.pad
    }

    /// The padded grid index of the first weight of the point `x` in [0, 1), and its offset
    /// `u` in [0, 1) for the piecewise polynomials.
    #[inline(always)]
    pub fn offset(&self, x: f64) -> (usize, f64) {
        let left = x * self.nf as f64 - self.w as f64 / 2.0;
        let l0 = left.ceil();
        ((l0 as i64 + self.pad as i64) as usize, l0 - left)
    }

    /// Kernel weights of the point `x` in [0, 1) from the piecewise polynomials: fills
    /// `out[..w]` (zero past `w`) and returns the padded grid index of the first weight.
    #[inline(always)]
    pub fn weights(&self, x: f64, out: &mut [f64; MAX_W]) -> usize {
        let (l0, u) = self.offset(x);
        let mut acc = [0.0f64; MAX_W];
        for c in self.horner.iter().rev() {
            for j in 0..MAX_W {
                acc[j] = acc[j].mul_add(u, c[j]);
            }
        }
        *out = acc;
        l0
    }

    /// Kernel weights of the point `x` evaluated from the kernel's formula (exp and sqrt).
    #[inline(always)]
    pub fn exact_weights(&self, x: f64, out: &mut [f64; MAX_W]) -> usize {
        let xs = x * self.nf as f64;
        let l0 = (xs - self.w as f64 / 2.0).ceil();
        let scale = 2.0 / self.w as f64;
        for (j, o) in out.iter_mut().enumerate() {
            let z = (l0 + j as f64 - xs) * scale;
            let s = (1.0 - z * z).max(0.0).sqrt();
            let v = exp_nonpos(self.beta * (s - 1.0));
            *o = if j < self.w && z * z <= 1.0 { v } else { 0.0 };
        }
        (l0 as i64 + self.pad as i64) as usize
    }

    /// From a spread grid of one channel (length `grid_len`, modified), the modes
    /// `k = -modes/2 .. modes - 1 - modes/2` into `out` (length `modes`).
    pub fn finish(&self, grid: &mut [Complex64], out: &mut [Complex64]) {
        let (nf, pad) = (self.nf, self.pad);
        debug_assert_eq!(grid.len(), self.grid_len());
        // Fold the padding back onto the periodic grid.
        for j in 0..pad {
            let lo = grid[j];
            grid[j + nf] += lo;
            let hi = grid[pad + nf + j];
            grid[pad + j] += hi;
        }
        let g = &mut grid[pad..pad + nf];
        // (the scratch is kept per thread: a fresh one per call would be an allocation and a
        // zeroing per channel)
        FFT_SCRATCH.with_borrow_mut(|scratch| {
            scratch.resize(self.fft.get_inplace_scratch_len(), Complex64::new(0.0, 0.0));
            self.fft.process_with_scratch(g, scratch);
        });
        // Mode k = i - modes/2 sits at k mod nf: the negative ones at the grid's end.
        let half = self.modes / 2;
        let (neg, nonneg) = out.split_at_mut(half);
        let (c_neg, c_nonneg) = self.correction.split_at(half);
        for ((o, &v), &c) in neg.iter_mut().zip(&g[nf - half..]).zip(c_neg) {
            *o = v * c;
        }
        for ((o, &v), &c) in nonneg.iter_mut().zip(&g[..]).zip(c_nonneg) {
            *o = v * c;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gauss_legendre_integrates_polynomials_exactly() {
        let (x, w) = gauss_legendre(10);
        let int = |p: i32| x.iter().zip(&w).map(|(&x, &w)| w * x.powi(p)).sum::<f64>();
        assert!((int(0) - 2.0).abs() < 1e-14);
        assert!((int(18) - 2.0 / 19.0).abs() < 1e-14);
        assert!(int(7).abs() < 1e-15);
    }

    #[test]
    fn polynomial_kernel_weights_match_the_kernel() {
        for eps in [1e-3, 1e-6, 1e-9, 1e-12] {
            let plan = Type1Plan::new(1201, eps).unwrap();
            let mut exact = [0.0; MAX_W];
            let mut worst: f64 = 0.0;
            for k in 0..1000 {
                let x = k as f64 / 1000.0 * 0.999 + 1e-4;
                let l0 = plan.exact_weights(x, &mut exact);
                let xs = x * plan.nf as f64;
                let u = (l0 as f64 - plan.pad as f64) - (xs - plan.w as f64 / 2.0);
                for j in 0..plan.w {
                    let p = plan.horner.iter().rev().fold(0.0, |acc, c| acc * u + c[j]);
                    worst = worst.max((p - exact[j]).abs());
                }
            }
            assert!(worst < eps * 0.1, "eps {eps:e}: {worst:e}");
        }
    }

    #[test]
    fn fft_sizes_are_smooth_and_even() {
        assert_eq!(fft_size(2402), 2430);
        assert_eq!(fft_size(7), 8);
        assert_eq!(fft_size(1), 2);
    }

    fn direct(points: &[f64], strengths: &[Complex64], modes: usize) -> Vec<Complex64> {
        let half = modes / 2;
        (0..modes)
            .map(|i| {
                let k = i as f64 - half as f64;
                points
                    .iter()
                    .zip(strengths)
                    .map(|(&x, &s)| s * Complex64::from_polar(1.0, -2.0 * PI * k * x))
                    .sum()
            })
            .collect()
    }

    #[test]
    fn type1_matches_the_direct_sum_to_its_tolerance() {
        let mut rnd = crate::test_util::uniforms(12345);
        let n = 300;
        let points: Vec<f64> = (0..n).map(|_| rnd()).collect();
        let strengths: Vec<Complex64> = (0..n)
            .map(|_| Complex64::new(rnd() - 0.5, rnd() - 0.5))
            .collect();
        for &(modes, eps) in &[(1201usize, 1e-3), (1201, 1e-6), (200, 1e-9), (201, 1e-12)] {
            let plan = Type1Plan::new(modes, eps).unwrap();
            let mut grid = vec![Complex64::new(0.0, 0.0); plan.grid_len()];
            let mut wts = [0.0; MAX_W];
            for (&x, &s) in points.iter().zip(&strengths) {
                let l0 = plan.weights(x, &mut wts);
                for j in 0..plan.w {
                    grid[l0 + j] += s * wts[j];
                }
            }
            let mut out = vec![Complex64::new(0.0, 0.0); modes];
            plan.finish(&mut grid, &mut out);
            let want = direct(&points, &strengths, modes);
            let num: f64 = out
                .iter()
                .zip(&want)
                .map(|(a, b)| (a - b).norm_sqr())
                .sum::<f64>()
                .sqrt();
            let den: f64 = want.iter().map(|b| b.norm_sqr()).sum::<f64>().sqrt();
            assert!(
                num / den < eps * 2.0,
                "modes {modes} eps {eps}: rel err {:e}",
                num / den
            );
        }
    }
}
