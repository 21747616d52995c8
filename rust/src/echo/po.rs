//! The physical-optics leaf over all bins: its smooth extension interpolated per block (the
//! C library's Bessel `j1` at the nodes only), its magnitude taken bin by bin.
use crate::echo::exact::accumulate_block;
use crate::echo::exact::block_poly;
use crate::echo::exact::last_coefficient;
use crate::echo::exact::phase_steps;
use crate::echo::tables::BandTables;
use crate::echo::tables::LANES;
use crate::echo::tables::NODES;
use crate::echo::tables::POLY_BLOCK;
use crate::echo::tables::POLY_DEG;
use crate::echo::tables::{lanes, lanes_mut};
use crate::echo::term::LeafTerm;
use crate::math::vmath::{exp_nonpos, j1_hankel, j1_interval, jinc_small, J1_EDGES};
use crate::physics::leaf::{self};
use crate::physics::phase::CyclesPerBin;
use multiversion::multiversion;

/// Largest last Chebyshev coefficient (of 7, relative to the block's peak) of an interpolated
/// physical-optics block: `g` oscillates, so it is held far below the paper factor's
/// [`CHEB_TOL`] (the interpolant's error then stays ~1e-12 of the block's peak).
const PO_CHEB_TOL: f64 = 1e-10;
/// Bins per physical-optics sub-block, tried where a whole block fails.
const PO_SUB_BLOCK: usize = 32;

/// Physical optics' smooth extension `g = amp (c^2/2) cos(beta) jinc(2 c sin(beta)) / k
/// [exp(-atten r)]` at wavenumber `k` (rad/m): the leaf's factor is `j |g|` (`psi = -pi/2`).
///
/// Mirrors [`crate::physics::leaf::physical_optics`] (before its magnitude), as do
/// [`po_extension_nodes`] and [`po_extension_bins`] in vector form; held to it by
/// `echo::tests::physical_optics_blocks_match_libm_at_every_bin`.
#[inline(always)]
fn po_extension(t: &LeafTerm, k: f64, atten: f64) -> f64 {
    let c = k * t.radius;
    let g = t.amp * (c * c / 2.0) * t.cos_beta * leaf::jinc(2.0 * c * t.sin_beta) / k;
    if atten == 0.0 {
        g
    } else {
        g * (-atten * t.range).exp()
    }
}

/// [`po_extension`] at an interpolation block's `LANES` nodes, wavenumbers `k` (with `1/k`
/// and the absorption `atten`, Np/m): vectorised where every lane's `x = 2 c sin(beta)` lies
/// in one of the C library's intervals for `J1` ([`j1_interval`]: the same rationals,
/// [`jinc_small`] below 2 and the Hankel form [`j1_hankel`] above); lanes that straddle two
/// intervals take libm's `j1` one by one.
#[inline(always)]
fn po_extension_nodes<const ATTEN: bool>(
    t: &LeafTerm,
    k: &[f64; LANES],
    inv_k: &[f64; LANES],
    atten: &[f64; LANES],
) -> [f64; LANES] {
    let mut x = [0.0; LANES];
    for i in 0..LANES {
        x[i] = 2.0 * (k[i] * t.radius) * t.sin_beta;
    }
    // (loops, not `array::from_fn`: its closure can be compiled outside the multiversioned
    // caller, where `mul_add` is a library call)
    let mut jinc = [0.0; LANES];
    if x.iter().all(|&x| x >= J1_EDGES[0]) {
        // leaves whose `g` oscillates across the band (the common case of `j1` per bin)
        jinc_hankel::<0>(&x, &mut jinc);
    } else {
        // (the intervals are contiguous: the lanes' least and greatest `x` decide)
        let (lo, hi) = x.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), &x| {
            (lo.min(x), hi.max(x))
        });
        match (j1_interval(lo), j1_interval(hi)) {
            (1, 1) => jinc_hankel::<1>(&x, &mut jinc),
            (2, 2) => jinc_hankel::<2>(&x, &mut jinc),
            (3, 3) => jinc_hankel::<3>(&x, &mut jinc),
            (4, 4) => {
                for i in 0..LANES {
                    jinc[i] = jinc_small(x[i]);
                }
            }
            _ => {
                return std::array::from_fn(|i| {
                    po_extension(t, k[i], if ATTEN { atten[i] } else { 0.0 })
                })
            }
        }
    }
    let mut g = [0.0; LANES];
    for i in 0..LANES {
        let c = k[i] * t.radius;
        // g = amp (c^2 / 2) cos(beta) (2 J1(x) / x) / k
        g[i] = t.amp * (c * c / 2.0) * t.cos_beta * jinc[i] * inv_k[i];
    }
    if ATTEN {
        for i in 0..LANES {
            g[i] *= exp_nonpos(-atten[i] * t.range);
        }
    }
    g
}

/// `|g|` ([`po_extension`]) at the bins `j0..j0 + LANES` of a block that failed its checks:
/// vectorised ([`j1_hankel`]) where every lane's `x` is at least 8 (the leaves whose `g`
/// oscillates across the band), otherwise libm's `j1` lane by lane. (Apart from
/// [`po_extension_nodes`], so that this loop stays small: the other intervals inlined here
/// slow it for leaves of a few centimetres.)
#[inline(always)]
fn po_extension_bins<const ATTEN: bool>(tab: &BandTables, t: &LeafTerm, j0: usize) -> [f64; LANES] {
    let (k, inv_k): (&[f64; LANES], &[f64; LANES]) = (lanes(&tab.k, j0), lanes(&tab.inv_k, j0));
    let mut x = [0.0; LANES];
    for i in 0..LANES {
        x[i] = 2.0 * (k[i] * t.radius) * t.sin_beta;
    }
    if !x.iter().all(|&x| x >= J1_EDGES[0]) {
        return std::array::from_fn(|i| {
            let a = if ATTEN { tab.atten[j0 + i] } else { 0.0 };
            po_extension(t, k[i], a).abs()
        });
    }
    let mut g = [0.0; LANES];
    for i in 0..LANES {
        let c = k[i] * t.radius;
        let inv_x = 1.0 / x[i];
        // g = amp (c^2 / 2) cos(beta) (2 J1(x) / x) / k
        g[i] = t.amp * (c * c) * t.cos_beta * (j1_hankel::<0>(x[i], inv_x) * inv_x) * inv_k[i];
    }
    if ATTEN {
        for (v, a) in g.iter_mut().zip(lanes(&tab.atten, j0)) {
            *v *= exp_nonpos(-a * t.range);
        }
    }
    for v in g.iter_mut() {
        *v = v.abs();
    }
    g
}

/// `2 J1(x) / x` on lanes in fdlibm's interval `IV` (0 to 3, `x >= 2`).
#[inline(always)]
fn jinc_hankel<const IV: usize>(x: &[f64; LANES], out: &mut [f64; LANES]) {
    for i in 0..LANES {
        let inv_x = 1.0 / x[i];
        out[i] = 2.0 * j1_hankel::<IV>(x[i], inv_x) * inv_x;
    }
}

/// Physical optics over all bins, per block of [`POLY_BLOCK`] bins: the smooth `g`
/// ([`po_extension`], the C library's Bessel `j1` at the block's nodes only) interpolated and
/// its magnitude taken bin by bin (`||p| - |g|| <= |p - g|`, so the diffraction nulls' corners
/// cost nothing); where a block fails the checks (large leaves: `g` oscillates within it),
/// `|g|` at every bin. The factor is `j |g|`.
#[multiversion(targets("x86_64+avx512f+avx512vl+avx512dq+avx2+fma", "x86_64+avx2+fma"))]
pub(super) fn po_blocks<const ATTEN: bool>(
    tab: &BandTables,
    t: &LeafTerm,
    q: &CyclesPerBin,
    re: &mut [f64],
    im: &mut [f64],
) {
    let nt = &tab.nodes;
    let (pw, w8) = phase_steps(q);
    let (mut zr, mut zi) = ([0.0; LANES], [0.0; LANES]);
    let zero = [0.0; LANES];
    // `|p(t)|` at the lanes' local variables `tl`, times `exp(-atten r)` per bin (`scale`).
    // (a loop, not `array::from_fn`, whose closure can be compiled outside this function)
    let interpolated = |cr: &[f64; NODES], tl: &[f64; LANES], j0: usize, scale: bool| {
        let mut out = [0.0; LANES];
        for i in 0..LANES {
            let mut r = cr[POLY_DEG];
            for p in (0..POLY_DEG).rev() {
                r = r.mul_add(tl[i], cr[p]);
            }
            out[i] = if ATTEN && scale {
                r.abs() * (-tab.atten[j0 + i] * t.range).exp()
            } else {
                r.abs()
            };
        }
        out
    };
    for b in 0..nt.n_blocks {
        let j_start = b * POLY_BLOCK;
        let j_end = if b + 1 == nt.n_blocks {
            tab.m_pad
        } else {
            j_start + POLY_BLOCK
        };
        let at = b * LANES;
        let nodes = po_extension_nodes::<ATTEN>(
            t,
            lanes(&nt.k, at),
            lanes(&nt.inv_k, at),
            if ATTEN { lanes(&nt.atten, at) } else { &zero },
        );
        let poly = block_poly(tab, &nodes, &zero, PO_CHEB_TOL);
        // Sub-blocks a quarter as wide shrink the last coefficient ~4^6-fold: try them only
        // where that can pass (with a factor 4 to spare).
        let try_sub = poly.is_none() && {
            let (last, peak) = last_coefficient(tab, &nodes, &zero);
            last <= 4.0 * 4096.0 * PO_CHEB_TOL * peak
        };
        for s0 in (j_start..j_end).step_by(PO_SUB_BLOCK) {
            // Where the block fails, its sub-blocks of PO_SUB_BLOCK bins are tried (`g`
            // without absorption at their own nodes; `exp(-atten r)` per bin), then `j1` per
            // bin.
            let s1 = (s0 + PO_SUB_BLOCK).min(j_end);
            let sub = try_sub.then(|| {
                let (c, h) = (
                    (s0 + s1 - 1) as f64 / 2.0,
                    ((s1 - s0 - 1) as f64 / 2.0).max(0.5),
                );
                let k_at = |x: f64| tab.k[0] * (tab.k0 + x) / tab.k0;
                let k: [f64; LANES] = std::array::from_fn(|i| {
                    k_at(if i < NODES {
                        c + h * tab.node_t[i]
                    } else {
                        c + h
                    })
                });
                let nodes = po_extension_nodes::<false>(t, &k, &k.map(|k| 1.0 / k), &zero);
                (block_poly(tab, &nodes, &zero, PO_CHEB_TOL), c, h)
            });
            for j0 in (s0..s1).step_by(LANES) {
                let fi: [f64; LANES] = match (&poly, &sub) {
                    (Some((cr, _)), _) => interpolated(cr, lanes(&tab.t, j0), j0, false),
                    (None, Some((Some((cr, _)), c, h))) => {
                        let tl = std::array::from_fn(|i| ((j0 + i) as f64 - c) / h);
                        interpolated(cr, &tl, j0, true)
                    }
                    _ => po_extension_bins::<ATTEN>(tab, t, j0),
                };
                accumulate_block(
                    false,
                    j0,
                    tab.k0,
                    q,
                    &pw,
                    w8,
                    &zero,
                    &fi,
                    &mut zr,
                    &mut zi,
                    lanes_mut(re, j0),
                    lanes_mut(im, j0),
                );
            }
        }
    }
}
