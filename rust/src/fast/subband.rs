//! Kinked paper-model leaves by sub-bands.
//!
//! A kinked leaf's factor `max(0, g)` is zero below its first live bin `m*` and the smooth
//! `g` above it. Over the whole band `g` needs about twice the nodes of a typical leaf, and
//! the corner costs the interpolant evaluated bin by bin over the shorter side (up to 600
//! bins): about a microsecond per leaf that fails a first pass's check, where many do.
//!
//! Here the band is cut into sub-bands of about [`SUB_BAND_BINS`] bins (at least
//! [`MIN_SUB_BANDS`] of them), each a sonar of its own (the same bins, wavenumbers and tables;
//! rectangular window). A sub-band wholly on the live side sees a smooth leaf over a band a
//! quarter as wide, where a few nodes suffice; the sub-band holding `m*` sees a kinked leaf over
//! ~300 bins and routes it as the full band would
//! (its interpolant subtracted on the zero side or added on the live side). Sub-bands wholly
//! on the zero side never see it. Each sub-band is a fast sum with the same tolerance, and each
//! leaf's check there is against its peak over the whole band ([`top_bin_magnitude`]), so the
//! error bound is the full band's.
//!
//! The sub-band sums come in two forms. [`SubBands::kinked_sum`] takes the leaves a whole
//! first pass left, after it; [`KinkPass`] lets each task of a first pass spread its own kinked
//! leaves onto sub-band grids of its own, which the pass then adds (used for passes of few
//! tasks, where a later pass would run mostly alone after them).
//!
//! Determinism: each sub-band takes the leaves live in it in the callers' order, and the
//! sub-bands are added into the band in order; a [`KinkPass`]'s tasks are those of the first
//! pass (a function of the leaf count), added in task order.

use crate::echo::term::LeafTerm;
use crate::error::Result;
use crate::fast::FastSonar;
use crate::fast::{
    choose_nodes_from, chunk_len, fast_sum_fixed, finish_grids, spread_task, Direct, FastPlan,
    K_FACTOR_TOL,
};
use crate::sonar::{LeafModel, Sonar, Window};
use rayon::prelude::*;
use std::sync::Arc;

/// Bins per sub-band, about (narrower sub-bands add each one's fixed cost, which shows at
/// 1e5 leaves).
pub const SUB_BAND_BINS: usize = 300;
/// The fewest sub-bands a band is cut into.
pub const MIN_SUB_BANDS: usize = 4;
/// Bands whose sub-bands would be narrower than this keep the full-band passes.
pub const MIN_SUB_BAND_BINS: usize = 130;
/// Sub-band calls with fewer leaves than this use the sub-band's worst-case node count.
const ADAPT_MIN: usize = 64;

/// The sub-bands of a sonar's band: their first bins (within the band) and their sonars.
#[derive(Clone)]
pub struct SubBands {
    pub bands: Vec<(usize, FastSonar)>,
}

impl std::fmt::Debug for SubBands {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "SubBands(first bins {:?})",
            self.bands.iter().map(|b| b.0).collect::<Vec<_>>()
        )
    }
}

impl SubBands {
    /// `None` where the band has fewer than `MIN_SUB_BANDS * MIN_SUB_BAND_BINS` bins (~520).
    pub fn new(sonar: &FastSonar) -> Result<Option<SubBands>> {
        let m = sonar.n_bins();
        let s = ((m + SUB_BAND_BINS / 2) / SUB_BAND_BINS).max(MIN_SUB_BANDS);
        if m / s < MIN_SUB_BAND_BINS {
            return Ok(None);
        }
        let df = sonar.params.fs / sonar.params.n_samples as f64;
        let mut bands = Vec::with_capacity(s);
        for b in 0..s {
            let (lo, hi) = (b * m / s, (b + 1) * m / s - 1);
            let mut p = sonar.params.clone();
            // the same bins: k0 + lo .. k0 + hi (round(k df / df) = k)
            p.f_lo = (sonar.k0 + lo) as f64 * df;
            p.f_hi = (sonar.k0 + hi) as f64 * df;
            p.window = Window::Rect;
            let sub = FastSonar::new(Sonar::new(p)?);
            if (sub.k0, sub.k1) != (sonar.k0 + lo, sonar.k0 + hi) {
                return Ok(None); // (cannot happen; the full-band passes would stand in)
            }
            bands.push((lo, sub));
        }
        Ok(Some(SubBands { bands }))
    }

    /// The node count for all sub-bands: chosen from a sample of the leaves smooth over the
    /// last sub-band (all but those whose corner lies in it), the worst case for few leaves.
    fn node_count(&self, tol: f64, leaves: &[KinkedLeaf]) -> Result<usize> {
        let (_, last) = self.bands.last().expect("sub-bands");
        let full = last.plans.get(last, tol)?;
        if leaves.len() < ADAPT_MIN {
            return Ok(full.p);
        }
        let stride = (leaves.len() / 256).max(1);
        let sample: Vec<&LeafTerm> = leaves.iter().step_by(stride).map(|k| &k.term).collect();
        let p = choose_nodes_from(last, &full, &sample);
        Ok(p)
    }

    /// The windowed band spectrum (of `sonar`, whose sub-bands these are) of kinked
    /// paper-model leaves (their first live bins and floors from [`KinkedLeaf::new`] at `tol`),
    /// to `tol`.
    pub(crate) fn kinked_sum(
        &self,
        sonar: &FastSonar,
        tol: f64,
        leaves: &[KinkedLeaf],
    ) -> Result<(Vec<f64>, Vec<f64>)> {
        let p = self.node_count(tol, leaves)?;
        let parts = self
            .bands
            .par_iter()
            .with_max_len(1)
            .map(|(lo, sub)| {
                // a sub-band's leaves: those live somewhere in it, in the callers' order
                let (terms, floors) = live_before(leaves, lo + sub.n_bins());
                band_sum(sub, tol, p, &terms, &floors).map(Some)
            })
            .collect::<Result<Vec<_>>>()?;
        Ok(self.in_band(sonar, parts))
    }

    /// The sub-bands' spectra (rectangular window; None for a sub-band with none) added into
    /// the band of `sonar`, whose window they take, in order.
    fn in_band(
        &self,
        sonar: &FastSonar,
        parts: Vec<Option<(Vec<f64>, Vec<f64>)>>,
    ) -> (Vec<f64>, Vec<f64>) {
        let m = sonar.n_bins();
        let (mut re, mut im) = (vec![0.0; m], vec![0.0; m]);
        for ((lo, _), part) in self.bands.iter().zip(parts) {
            let Some((pr, pi)) = part else { continue };
            for j in 0..pr.len() {
                re[lo + j] += sonar.window[lo + j] * pr[j];
                im[lo + j] += sonar.window[lo + j] * pi[j];
            }
        }
        (re, im)
    }
}

/// The sub-bands with their plans at one node count, for the kinked leaves of a fast pass:
/// each task spreads its own onto sub-band grids of its own ([`KinkPass::spread`]), beside
/// its share of the band, and the pass adds the tasks' shares ([`KinkPass::finish`]). (Left
/// to a later pass, these leaves would be its bulk at 1e5 leaves and run after the band's
/// tasks.)
pub(crate) struct KinkPass {
    subs: Arc<SubBands>,
    plans: Vec<Arc<FastPlan>>,
}

/// One task's kinked leaves on the sub-bands: per sub-band, None where none of them is live
/// there, else its spread grid and its direct bins (the leaves it could not take summed
/// exactly there).
pub(crate) struct KinkedShare {
    bands: Vec<Option<(Vec<f64>, Direct)>>,
}

impl KinkPass {
    /// For `sonar`'s paper-model fast passes at `tol` with `p` nodes: the sub-bands take the
    /// same count (capped at their worst case), the count chosen for the band's leaves. None
    /// where the band has no sub-bands or the model is not the paper's.
    pub(crate) fn new(sonar: &FastSonar, tol: f64, p: usize) -> Option<KinkPass> {
        if sonar.params.leaf_model != LeafModel::Paper {
            return None;
        }
        let subs = sonar.sub_bands()?;
        let plans = subs
            .bands
            .iter()
            .map(|(_, sub)| {
                let most = sub.plans.get(sub, tol)?.p;
                sub.plans.get_with_nodes(sub, tol, p.min(most))
            })
            .collect::<Result<Vec<_>>>()
            .ok()?;
        Some(KinkPass { subs, plans })
    }

    /// One task's kinked leaves (in its order) onto its sub-band grids: each sub-band takes
    /// the leaves live somewhere in it.
    pub(crate) fn spread(&self, leaves: &[KinkedLeaf]) -> KinkedShare {
        let bands = self
            .subs
            .bands
            .iter()
            .zip(&self.plans)
            .map(|((lo, sub), plan)| {
                let (terms, floors) = live_before(leaves, lo + sub.n_bins());
                (!terms.is_empty()).then(|| spread_task(sub, plan, &terms, &floors))
            })
            .collect();
        KinkedShare { bands }
    }

    /// The windowed band spectrum (of `sonar`, whose sub-bands these are) of the tasks'
    /// shares (in task order; None where no task had a kinked leaf): per sub-band, its grids
    /// and direct bins summed in that order, its transforms, the sub-bands added in order.
    pub(crate) fn finish(
        &self,
        sonar: &FastSonar,
        shares: Vec<KinkedShare>,
    ) -> Option<(Vec<f64>, Vec<f64>)> {
        let nb = self.subs.bands.len();
        let mut per_band: Vec<(Vec<Vec<f64>>, Option<Direct>)> =
            (0..nb).map(|_| (Vec::new(), None)).collect();
        for share in shares {
            for ((grids, direct), band) in per_band.iter_mut().zip(share.bands) {
                if let Some((g, d)) = band {
                    grids.push(g);
                    match direct {
                        Some(acc) => acc.add(&d),
                        None => *direct = Some(d),
                    }
                }
            }
        }
        if per_band.iter().all(|(g, _)| g.is_empty()) {
            return None;
        }
        let parts: Vec<Option<(Vec<f64>, Vec<f64>)>> = per_band
            .into_par_iter()
            .zip(&self.subs.bands)
            .zip(&self.plans)
            .with_max_len(1)
            .map(|(((grids, direct), (_, sub)), plan)| {
                let d = direct?;
                Some(finish_grids(sub, plan, grids, (d.re, d.im)))
            })
            .collect();
        Some(self.subs.in_band(sonar, parts))
    }
}

/// A kinked paper-model leaf for the sub-bands: its term, first live bin in the band and
/// error floor ([`top_bin_magnitude`]). A first pass makes these for the leaves it defers, in
/// its own tasks.
#[derive(Clone, Copy, Debug)]
pub(crate) struct KinkedLeaf {
    pub(crate) term: LeafTerm,
    pub(crate) live_from: usize,
    pub(crate) floor: f64,
}

impl KinkedLeaf {
    /// The leaf `t` of `sonar`'s band whose first live bin is `live_from`, for tolerance `tol`.
    #[inline(always)]
    pub(crate) fn new(sonar: &FastSonar, tol: f64, t: LeafTerm, live_from: usize) -> KinkedLeaf {
        KinkedLeaf {
            term: t,
            live_from,
            floor: top_bin_magnitude(sonar, tol, &t),
        }
    }

    /// [`KinkedLeaf::new`] with the first live bin found here.
    #[cfg(test)]
    fn of(sonar: &FastSonar, tol: f64, t: LeafTerm) -> KinkedLeaf {
        let live_from = crate::fast::kinks::kink_bin(sonar, t.radius_pow_b, t.beta);
        KinkedLeaf::new(sonar, tol, t, live_from)
    }
}

/// The leaves live before band bin `end` (first live bin below it), in order, with their
/// floors.
fn live_before(leaves: &[KinkedLeaf], end: usize) -> (Vec<LeafTerm>, Vec<f64>) {
    let (mut terms, mut floors) = (
        Vec::with_capacity(leaves.len()),
        Vec::with_capacity(leaves.len()),
    );
    for k in leaves.iter().filter(|k| k.live_from < end) {
        terms.push(k.term);
        floors.push(k.floor);
    }
    (terms, floors)
}

/// One sub-band's fast sum at `p` nodes, the leaves that fail the check summed exactly (over
/// this sub-band only).
fn band_sum(
    sub: &FastSonar,
    tol: f64,
    p: usize,
    terms: &[LeafTerm],
    floors: &[f64],
) -> Result<(Vec<f64>, Vec<f64>)> {
    if terms.is_empty() {
        let m = sub.n_bins();
        return Ok((vec![0.0; m], vec![0.0; m]));
    }
    let plan = sub.plans.get_with_nodes(sub, tol, p)?;
    Ok(fast_sum_fixed(
        sub,
        &plan,
        terms,
        floors,
        chunk_len(terms.len(), plan.nufft.nf),
    ))
}

/// The magnitude of a kinked leaf's channel value at the band's last bin, where it is live: a
/// lower bound of its peak over the band, the scale of its error budget (the full band's check
/// measures the error against the peak on the live side; a sub-band near the corner sees only
/// small values). Channels carry `k F` below [`K_FACTOR_TOL`], `F` above.
///
/// Mirrors [`crate::physics::leaf::paper`]'s `L` at one bin (with the table's `k^-0.9065`);
/// held to the exact sum by
/// `fast::subband::tests::the_error_floor_is_the_leafs_channel_value_at_the_last_bin`.
#[inline(always)]
fn top_bin_magnitude(sonar: &FastSonar, tol: f64, t: &LeafTerm) -> f64 {
    use crate::physics::leaf::{PAPER_A0, PAPER_A2, PAPER_B0, PAPER_B1};
    let j = sonar.n_bins() - 1;
    let k = sonar.wavenumbers[j];
    let c = k * t.radius;
    let b = PAPER_B1.mul_add(sonar.tables.kp[j] * t.radius_pow_b, PAPER_B0);
    let l = ((PAPER_A2 * c).mul_add(c, PAPER_A0) * (b * t.beta).cos()).max(0.0);
    let atten = sonar
        .atten_per_m
        .get(j)
        .map_or(1.0, |a| (-a * t.range).exp());
    let f = t.amp * l * atten;
    if tol < K_FACTOR_TOL {
        f
    } else {
        f / k
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::echo::spectrum::sum_terms;
    use crate::echo::{paper_regime, PaperRegime};
    use crate::physics::absorption::Atmosphere;
    use crate::test_util::{rel_l2_pair as rel_l2, sonar_with, uniforms};

    fn sonar(atm: Option<Atmosphere>, window: Window) -> FastSonar {
        sonar_with(|p| {
            p.atmosphere = atm;
            p.window = window;
        })
    }

    /// The leaves with their first live bins and floors, as a first pass gives them.
    fn keyed(s: &FastSonar, tol: f64, t: &[LeafTerm]) -> Vec<KinkedLeaf> {
        t.iter().map(|&t| KinkedLeaf::of(s, tol, t)).collect()
    }

    /// `n` kinked leaves: radii 3 mm - 10 cm, near and far.
    fn kinked(s: &FastSonar, n: usize, seed: u64) -> Vec<LeafTerm> {
        let mut u = uniforms(seed);
        std::iter::repeat_with(|| {
            let radius = 0.003 * (100.0f64 / 3.0).powf(u());
            let range = 0.1 + 10.0 * u();
            let beta = u() * std::f64::consts::FRAC_PI_2;
            LeafTerm::new(0.2 / (range * range), range, beta, radius)
        })
        .filter(|t| paper_regime(&s.tables, t) == PaperRegime::Kinked)
        .take(n)
        .collect()
    }

    #[test]
    fn sub_bands_tile_the_band_with_its_own_bins() {
        // the default band: 1201 bins in four sub-bands of ~300; 70-80 kHz: 601 bins in four
        // of ~150; 40-80 kHz: 2401 bins in eight of ~300
        for (f_lo, count, bins) in [(60e3, 4, SUB_BAND_BINS), (70e3, 4, 150), (40e3, 8, 300)] {
            let s = sonar_with(|p| p.f_lo = f_lo);
            let subs = SubBands::new(&s).unwrap().unwrap();
            assert_eq!(subs.bands.len(), count, "f_lo {f_lo}");
            let mut next = 0;
            for (lo, sub) in &subs.bands {
                let n = sub.n_bins();
                assert_eq!(*lo, next);
                assert!((bins - 2..=bins + 2).contains(&n), "f_lo {f_lo}: {n}");
                assert_eq!(sub.wavenumbers[..], s.wavenumbers[*lo..lo + n]);
                assert_eq!(sub.tables.kp[..n], s.tables.kp[*lo..lo + n]);
                assert!(sub.window.iter().all(|&w| w == 1.0));
                next += n;
            }
            assert_eq!(next, s.n_bins());
        }
    }

    #[test]
    fn a_band_of_fewer_than_four_sub_bands_has_none() {
        let s = sonar_with(|p| p.f_lo = 75e3); // 301 bins
        assert!(SubBands::new(&s).unwrap().is_none());
    }

    #[test]
    fn kinked_sum_is_within_tol_of_the_exact_sum() {
        for atm in [None, Some(Atmosphere::default())] {
            let s = sonar(atm, Window::Hann);
            let subs = s.sub_bands().unwrap();
            let t = kinked(&s, 3000, 1);
            let exact = sum_terms(&s, &t);
            for tol in [1e-3, 1e-6, 1e-9, 1e-12] {
                let err = rel_l2(
                    &subs.kinked_sum(&s, tol, &keyed(&s, tol, &t)).unwrap(),
                    &exact,
                );
                assert!(err <= tol, "atm {} tol {tol:e}: {err:e}", atm.is_some());
            }
            // each leaf alone (its own peak sets the scale), corners near either band edge
            for leaf in kinked(&s, 60, 2) {
                let one = std::slice::from_ref(&leaf);
                let err = rel_l2(
                    &subs.kinked_sum(&s, 1e-9, &keyed(&s, 1e-9, one)).unwrap(),
                    &sum_terms(&s, one),
                );
                assert!(err <= 1e-9, "{leaf:?}: {err:e}");
            }
        }
    }

    #[test]
    fn kinked_sum_is_bit_identical_for_one_and_two_threads() {
        let s = sonar(None, Window::Hann);
        let subs = s.sub_bands().unwrap();
        let t = keyed(&s, 1e-6, &kinked(&s, 20_000, 3));
        let a = subs.kinked_sum(&s, 1e-6, &t).unwrap();
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap();
        let b = pool.install(|| subs.kinked_sum(&s, 1e-6, &t).unwrap());
        assert_eq!(a, b);
    }

    #[test]
    fn the_error_floor_is_the_leafs_channel_value_at_the_last_bin() {
        for atm in [None, Some(Atmosphere::default())] {
            let s = sonar(atm, Window::Rect);
            let j = s.n_bins() - 1;
            for leaf in kinked(&s, 50, 4) {
                let (re, im) = sum_terms(&s, std::slice::from_ref(&leaf));
                let f = re[j].hypot(im[j]);
                let lo = top_bin_magnitude(&s, 1e-3, &leaf);
                assert!((lo - f).abs() <= 1e-12 * f, "{lo:e} {f:e}");
                let hi = top_bin_magnitude(&s, 1e-6, &leaf);
                let kf = s.wavenumbers[j] * f;
                assert!((hi - kf).abs() <= 1e-12 * kf, "{hi:e} {kf:e}");
            }
        }
    }

    #[test]
    fn with_their_floors_few_kinked_leaves_fall_to_the_exact_sum_in_a_sub_band() {
        let s = sonar(None, Window::Hann);
        let subs = s.sub_bands().unwrap();
        let leaves = keyed(&s, 1e-6, &kinked(&s, 3000, 5));
        let (terms, floors): (Vec<LeafTerm>, Vec<f64>) =
            leaves.iter().map(|k| (k.term, k.floor)).unzip();
        let p = subs.node_count(1e-6, &leaves).unwrap();
        assert!(p <= 5, "{p}");
        let n = terms.len();
        for (b, (lo, sub)) in subs.bands.iter().enumerate() {
            let plan = sub.plans.get_with_nodes(sub, 1e-6, p).unwrap();
            let f = crate::fast::pass::spread_pass(sub, &plan, &terms, &floors, 1024, None, false);
            // (in the last sub-band, leaves whose corner lies there have a small value at the
            // top bin, the floor of their budget)
            let most = if b + 1 == subs.bands.len() {
                n / 10
            } else {
                n / 100
            };
            assert!(
                f.deferred.len() <= most,
                "at {lo}: {} of {n}",
                f.deferred.len()
            );
        }
    }
}
