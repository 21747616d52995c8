//! Impulse response from the band spectrum: `y = 2 irfft(Y, n)` with NumPy's normalisation
//! (the inverse divides by n), via realfft. Plans are cached per length.

use realfft::num_complex::Complex64;
use realfft::{ComplexToReal, RealFftPlanner};
use std::collections::HashMap;
use std::sync::{Arc, Mutex, OnceLock};

type Plan = Arc<dyn ComplexToReal<f64>>;

fn plan(n: usize) -> Plan {
    static PLANS: OnceLock<Mutex<HashMap<usize, Plan>>> = OnceLock::new();
    let plans = PLANS.get_or_init(|| Mutex::new(HashMap::new()));
    let mut guard = plans.lock().unwrap_or_else(|e| e.into_inner());
    guard
        .entry(n)
        .or_insert_with(|| RealFftPlanner::<f64>::new().plan_fft_inverse(n))
        .clone()
}

/// Write `2 irfft(Y, n)` into `out` (length n), where `Y` is zero except on bins
/// `k0 .. k0 + re.len()`.
pub fn impulse_from_band(n: usize, k0: usize, re: &[f64], im: &[f64], out: &mut [f64]) {
    assert_eq!(out.len(), n);
    let c2r = plan(n);
    let mut spec = c2r.make_input_vec();
    for j in 0..re.len() {
        spec[k0 + j] = Complex64::new(re[j], im[j]);
    }
    // As NumPy does: the imaginary parts of DC and (for even n) Nyquist are ignored.
    spec[0].im = 0.0;
    if n.is_multiple_of(2) {
        let last = spec.len() - 1;
        spec[last].im = 0.0;
    }
    let mut scratch = c2r.make_scratch_vec();
    c2r.process_with_scratch(&mut spec, out, &mut scratch)
        .expect("lengths are consistent and DC/Nyquist imaginary parts are zero");
    let scale = 2.0 / n as f64;
    for y in out.iter_mut() {
        *y *= scale;
    }
}
