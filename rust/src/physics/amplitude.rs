//! A leaf's echo amplitude before the leaf model (docs/model.md sections 3 and 5): the spreading
//! law `g G / r^2` (`g G / (r_tx r_rx)` for a receiver of its own), and the detectable rule's
//! constant `K`, with which a leaf of two-way gain `G` counts out to `r^2 <= K G`.

/// The amplitude `g G / r^2` of a leaf at range `r` (m) with two-way gain `G`, for the system
/// gain `g`; `g G` with spreading off.
#[inline(always)]
pub fn echo_amplitude(system_gain: f64, two_way_gain: f64, range: f64, spreading: bool) -> f64 {
    let amp = system_gain * two_way_gain;
    if spreading {
        amp / (range * range)
    } else {
        amp
    }
}

/// The bistatic amplitude `g G / (r_tx r_rx)` (docs/model.md §5a), `G = S_tx S_rx`; `g G`
/// with spreading off. The same operations as [`echo_amplitude`] (the gain product first), so
/// that `r_tx = r_rx = r` gives its bits.
#[inline(always)]
pub fn bistatic_echo_amplitude(
    system_gain: f64,
    two_way_gain: f64,
    r_tx: f64,
    r_rx: f64,
    spreading: bool,
) -> f64 {
    let amp = system_gain * two_way_gain;
    if spreading {
        amp / (r_tx * r_rx)
    } else {
        amp
    }
}

/// The detectable rule's constant `K = r0^2 p0 / (10^(T/20) p_ref)` (m^2): a source of
/// pressure `p0` at `r0` is detectable at `r` while `r^2 <= K G`, `T` the threshold (dB) over
/// `p_ref`.
pub fn detection_constant(threshold_db: f64, r0: f64, p0: f64, p_ref: f64) -> f64 {
    r0 * r0 * p0 / (10f64.powf(threshold_db / 20.0) * p_ref)
}
