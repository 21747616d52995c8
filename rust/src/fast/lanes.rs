//! A batch of up to [`LB`] paper-model leaves as lanes (fields side by side), filled from terms
//! or from a block of candidates, with each kinked leaf's first live bin.
use crate::echo::term::LeafTerm;
use crate::echo::{paper_regime, paper_regime_bits, PaperRegime, REGIME_KINKED, REGIME_ZERO};
use crate::fast::kinks::kink_bin;
use crate::fast::plan::FastPlan;
use crate::fast::prepared::FastSonar;
use crate::fast::subband::KinkedLeaf;

/// The most lanes that add nothing in a block of leaves batched whole: each costs a lane of
/// the batch's vector work, about three times what routing a counting leaf alone costs.
const MAX_SKIP: usize = 4;

/// Leaves per vector batch of the fast path (16: two AVX-512 vectors per operation, for
/// overlapping dependent chains).
pub(crate) const LB: usize = 16;

/// A batch of up to [`LB`] paper-model leaves as lanes (leaf fields side by side), with the
/// first live bin of each kinked leaf ([`NOT_KINKED`] for smooth ones); [`PaperLanes::pad`]
/// fills the missing lanes with the last leaf.
#[derive(Clone, Copy)]
pub(crate) struct PaperLanes {
    pub(crate) n: usize,
    pub(crate) amp: [f64; LB],
    pub(crate) range: [f64; LB],
    pub(crate) beta: [f64; LB],
    /// Radius, `radius^-0.9065`, `radius^0.3523`.
    pub(crate) a: [f64; LB],
    pub(crate) ap: [f64; LB],
    pub(crate) aq: [f64; LB],
    pub(crate) kink: [usize; LB],
    /// A lower bound of the leaf's peak over the whole band, for the smoothness check (0 when
    /// only this band is known; see [`crate::fast::subband`]).
    pub(crate) floor: [f64; LB],
    /// Lanes that add nothing (outside the lobe, or `L = 0` at every bin), in a batch only to
    /// keep a block of candidates whole: computed, never spread, never deferred.
    pub(crate) skip: [bool; LB],
}

/// [`PaperLanes`]' kink entry of a smooth leaf.
pub(crate) const NOT_KINKED: usize = usize::MAX;

impl PaperLanes {
    pub(crate) fn new() -> PaperLanes {
        let z = [0.0; LB];
        PaperLanes {
            n: 0,
            amp: z,
            range: z,
            beta: z,
            a: z,
            ap: z,
            aq: z,
            kink: [NOT_KINKED; LB],
            floor: z,
            skip: [false; LB],
        }
    }

    /// Lanes of up to `LB` terms (smooth or kinked, with their first live bins).
    pub(super) fn of(sonar: &FastSonar, terms: &[&LeafTerm]) -> PaperLanes {
        let mut l = PaperLanes::new();
        for t in terms {
            let kink = match paper_regime(&sonar.tables, t) {
                PaperRegime::Kinked => kink_bin(sonar, t.radius_pow_b, t.beta),
                _ => NOT_KINKED,
            };
            l.push(t, kink);
        }
        l.pad();
        l
    }

    /// A full block of smooth terms as lanes.
    #[inline(always)]
    pub(super) fn of_block(block: &[LeafTerm; LB]) -> PaperLanes {
        let mut l = PaperLanes::new();
        for t in block {
            l.push(t, NOT_KINKED);
        }
        l
    }

    /// [`PaperLanes::of_block`] by an in-register transpose of eight 64-byte terms at a time
    /// (cheaper than the gathers the compiler makes of [`PaperLanes::of_block`]).
    ///
    /// # Safety
    /// The CPU must have AVX-512F.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f")]
    pub(super) unsafe fn of_block_avx512(block: &[LeafTerm; LB]) -> PaperLanes {
        use std::arch::x86_64::*;
        const { assert!(std::mem::size_of::<LeafTerm>() == 64 && LB.is_multiple_of(8)) };
        let mut l = PaperLanes::new();
        for h in 0..LB / 8 {
            // rows: the terms' eight fields in declaration order (`LeafTerm` is `repr(C)`)
            let r: [__m512d; 8] =
                std::array::from_fn(|k| _mm512_loadu_pd(&block[8 * h + k].amp as *const f64));
            let t: [__m512d; 8] = std::array::from_fn(|k| {
                let (a, b) = (r[k & !1], r[k | 1]);
                if k % 2 == 0 {
                    _mm512_unpacklo_pd(a, b)
                } else {
                    _mm512_unpackhi_pd(a, b)
                }
            });
            // u[g]: fields g and g + 4 of rows 0-3 (g < 4) or 4-7 (g >= 4)
            let u: [__m512d; 8] = std::array::from_fn(|g| {
                let base = g & 4;
                let (a, b) = (t[base + (g & 1)], t[base + 2 + (g & 1)]);
                if g & 2 == 0 {
                    _mm512_shuffle_f64x2::<0x88>(a, b)
                } else {
                    _mm512_shuffle_f64x2::<0xdd>(a, b)
                }
            });
            let field = |f: usize| {
                let (a, b) = (u[f & 3], u[4 + (f & 3)]);
                if f < 4 {
                    _mm512_shuffle_f64x2::<0x88>(a, b)
                } else {
                    _mm512_shuffle_f64x2::<0xdd>(a, b)
                }
            };
            let at = 8 * h;
            _mm512_storeu_pd(l.amp[at..].as_mut_ptr(), field(0));
            _mm512_storeu_pd(l.range[at..].as_mut_ptr(), field(1));
            _mm512_storeu_pd(l.beta[at..].as_mut_ptr(), field(2));
            _mm512_storeu_pd(l.a[at..].as_mut_ptr(), field(5));
            _mm512_storeu_pd(l.ap[at..].as_mut_ptr(), field(6));
            _mm512_storeu_pd(l.aq[at..].as_mut_ptr(), field(7));
        }
        l.n = LB;
        l
    }

    #[inline(always)]
    pub(crate) fn push(&mut self, t: &LeafTerm, kink: usize) {
        let i = self.n;
        self.amp[i] = t.amp;
        self.range[i] = t.range;
        self.beta[i] = t.beta;
        self.a[i] = t.radius;
        self.ap[i] = t.radius_pow_b;
        self.aq[i] = t.radius_pow_p;
        self.kink[i] = kink;
        self.floor[i] = 0.0;
        self.skip[i] = false;
        self.n = i + 1;
    }

    /// Append lane `k` of `from`, with its first live bin.
    #[inline(always)]
    pub(crate) fn push_lane(&mut self, from: &PaperLanes, k: usize, kink: usize) {
        let i = self.n;
        self.amp[i] = from.amp[k];
        self.range[i] = from.range[k];
        self.beta[i] = from.beta[k];
        self.a[i] = from.a[k];
        self.ap[i] = from.ap[k];
        self.aq[i] = from.aq[k];
        self.kink[i] = kink;
        self.floor[i] = from.floor[k];
        self.skip[i] = false;
        self.n = i + 1;
    }

    /// Ready a full block of lanes (`n = LB`) to go into a batch whole, where each lane is
    /// `out` (not counting: outside the lobe) or `inside` and smooth, kinked or zero at every
    /// bin, and at most [`MAX_SKIP`] lanes add nothing: marks those `skip` (with finite
    /// values, for the batch's unused arithmetic) and gives kinked lanes their first live bin.
    /// False, the lanes' values untouched (their `skip` marks aside), where the block must go
    /// leaf by leaf.
    /// (Inlined: compiled apart from the multiversioned kernels, its `mul_add` would be a
    /// library call.)
    #[inline(always)]
    pub(crate) fn ready_whole(
        &mut self,
        sonar: &FastSonar,
        out: &[bool; LB],
        inside: &[bool; LB],
    ) -> bool {
        let (mut whole, mut n_skip) = (self.n == LB, 0);
        let mut kinked = [false; LB];
        #[allow(clippy::needless_range_loop)]
        for k in 0..LB {
            let bits = paper_regime_bits(&sonar.tables, self.ap[k], self.beta[k]);
            whole &= out[k] | (inside[k] & (bits != 0));
            self.skip[k] = out[k] | (inside[k] & (bits == REGIME_ZERO));
            kinked[k] = inside[k] & (bits == REGIME_KINKED);
            n_skip += usize::from(self.skip[k]);
        }
        if !(whole && n_skip <= MAX_SKIP) {
            return false;
        }
        #[allow(clippy::needless_range_loop)]
        for k in 0..LB {
            if kinked[k] {
                self.kink[k] = kink_bin(sonar, self.ap[k], self.beta[k]);
            }
            if self.skip[k] {
                // (an out lane may be at range 0)
                (self.amp[k], self.range[k], self.beta[k]) = (0.0, 1.0, 0.0);
            }
        }
        true
    }

    /// Lane `i`, a kinked leaf, for the sub-bands (its first live bin and its floor at the
    /// plan's tolerance); None for a smooth one.
    #[inline(always)]
    pub(crate) fn kinked_leaf(
        &self,
        sonar: &FastSonar,
        plan: &FastPlan,
        i: usize,
    ) -> Option<KinkedLeaf> {
        (self.kink[i] != NOT_KINKED)
            .then(|| KinkedLeaf::new(sonar, plan.tol, self.term(i), self.kink[i]))
    }

    /// Lane `i` as a term (its `cos beta`, `sin beta`, which the paper model does not use,
    /// from `beta`).
    pub(crate) fn term(&self, i: usize) -> LeafTerm {
        let (sin_beta, cos_beta) = self.beta[i].sin_cos();
        LeafTerm {
            amp: self.amp[i],
            range: self.range[i],
            beta: self.beta[i],
            cos_beta,
            sin_beta,
            radius: self.a[i],
            radius_pow_b: self.ap[i],
            radius_pow_p: self.aq[i],
        }
    }

    /// Repeat the last leaf in the missing lanes (as smooth: they are computed, never spread).
    pub(crate) fn pad(&mut self) {
        let n = self.n;
        if n == 0 {
            return;
        }
        for i in n..LB {
            self.amp[i] = self.amp[n - 1];
            self.range[i] = self.range[n - 1];
            self.beta[i] = self.beta[n - 1];
            self.a[i] = self.a[n - 1];
            self.ap[i] = self.ap[n - 1];
            self.aq[i] = self.aq[n - 1];
            self.kink[i] = NOT_KINKED;
            self.floor[i] = self.floor[n - 1];
        }
    }
}
