//! Spreading onto the NUFFT grid: the kernel weights of a leaf's offset (Horner chains, or the
//! mirror form of an eight-tap kernel) times its strengths, added to every channel.
use crate::echo::cis_neg;
use crate::fast::lanes::LB;
use crate::fast::nufft::MAX_W;
use crate::fast::plan::FastPlan;
use crate::fast::plan::MAX_NODES;
use crate::fast::prepared::FastSonar;
use crate::physics::phase::CyclesPerBin;

/// Add one leaf's weighted strengths to every channel. Channel `c` is a run of complex values
/// (real, imaginary interleaved) at `grid[2 c glen..]`; the leaf adds `w_j s(c)` (`s(c)`: its
/// strength there as `[re, im]`) to its points `l0 + j`: one contiguous run of `WS2` values per
/// channel.
#[inline(always)]
fn spread_channels<const WS2: usize>(
    grid: &mut [f64],
    glen: usize,
    p: usize,
    l0: usize,
    w2: &[f64; WS2],
    s: impl Fn(usize) -> [f64; 2],
) {
    let a = 2 * l0;
    let p = p.min(MAX_NODES);
    // One bounds check per leaf: every channel's run lies in its plane and the grid.
    assert!(a + WS2 <= 2 * glen && 2 * glen * p <= grid.len());
    let base = grid.as_mut_ptr();
    for c in 0..p {
        let [r, i] = s(c);
        let sv: [f64; WS2] = std::array::from_fn(|t| if t % 2 == 0 { r } else { i });
        // SAFETY: `2 c glen + a + WS2 <= 2 (c + 1) glen <= grid.len()` (asserted above), and
        // `grid` is borrowed mutably for the whole call.
        let run = unsafe { &mut *(base.add(2 * c * glen + a) as *mut [f64; WS2]) };
        for t in 0..WS2 {
            run[t] = w2[t].mul_add(sv[t], run[t]);
        }
    }
}

/// Spread one leaf at grid index `l0`, offset `u`: its strengths `sc` (one `[re, im]` per
/// channel) times its kernel weights.
#[inline(always)]
pub(super) fn spread_one(
    plan: &FastPlan,
    grid: &mut [f64],
    u: f64,
    l0: usize,
    sc: &[[f64; 2]; MAX_NODES],
) {
    let (p, glen, h) = (plan.p, plan.nufft.grid_len(), &plan.nufft.horner[..]);
    let s = |c: usize| sc[c];
    match plan.nufft.w {
        w @ 0..=8 => {
            let w = &if w == 8 {
                weights4_mirror(&plan.nufft.mirror, [u; 4])
            } else {
                weights4::<8>(h, [u; 4])
            }[0];
            spread_channels::<16>(grid, glen, p, l0, &std::array::from_fn(|t| w[t / 2]), s)
        }
        _ => {
            let w = &weights4::<16>(h, [u; 4])[0];
            spread_channels::<32>(grid, glen, p, l0, &std::array::from_fn(|t| w[t / 2]), s)
        }
    }
}

/// Spread one scatterer at round-trip delay `range` (m) with its factor at the plan's nodes
/// (`fr`, `fi`): the factor times the phase at the centre bin `m_c`, onto the point of the
/// delay's fractional part.
#[inline(always)]
pub(crate) fn spread_at(
    sonar: &FastSonar,
    plan: &FastPlan,
    range: f64,
    fr: &[f64; MAX_NODES],
    fi: &[f64; MAX_NODES],
    grid: &mut [f64],
) {
    let sp = &sonar.params;
    let q = CyclesPerBin::new(range, sp.fs, sp.n_samples, sp.sound_speed);
    let mut x = q.frac_at(1.0);
    if x < 0.0 {
        x += 1.0;
    }
    let (pr, pi) = cis_neg(q.frac_at(sonar.tables.k0 + plan.m_c as f64));
    let (l0, u) = plan.nufft.offset(x);
    let mut sc = [[0.0; 2]; MAX_NODES];
    for c in 0..plan.p {
        sc[c] = [fr[c] * pr - fi[c] * pi, fr[c] * pi + fi[c] * pr];
    }
    spread_one(plan, grid, u, l0, &sc);
}

/// The kernel weights of four points at offsets `u` in [0, 1) (zero past the kernel's width):
/// four independent Horner chains, eight taps at a time (the shape the compiler keeps in
/// vector registers; a loop over all `WS` taps is scalarised at sixteen).
#[inline(always)]
pub(super) fn weights4<const WS: usize>(h: &[[f64; MAX_W]], u: [f64; 4]) -> [[f64; WS]; 4] {
    let mut a = [[0.0f64; WS]; 4];
    let [u0, u1, u2, u3] = u;
    for t0 in (0..WS).step_by(8) {
        let mut b = [[0.0f64; 8]; 4];
        for c in h.iter().rev() {
            let c: &[f64; 8] = c[t0..t0 + 8].try_into().unwrap();
            for t in 0..8 {
                b[0][t] = b[0][t].mul_add(u0, c[t]);
                b[1][t] = b[1][t].mul_add(u1, c[t]);
                b[2][t] = b[2][t].mul_add(u2, c[t]);
                b[3][t] = b[3][t].mul_add(u3, c[t]);
            }
        }
        for k in 0..4 {
            a[k][t0..t0 + 8].copy_from_slice(&b[k]);
        }
    }
    a
}

/// [`weights4`] for an eight-tap kernel from its mirror form ([`Type1Plan::mirror`]): one
/// Horner chain in `v^2` gives the even and odd parts of taps 0-3 side by side, and
/// `E + v O`, `E - v O` are taps `j` and `7 - j`.
#[inline(always)]
pub(super) fn weights4_mirror(m: &[[f64; 8]], u: [f64; 4]) -> [[f64; 8]; 4] {
    let v: [f64; 4] = std::array::from_fn(|k| u[k] - 0.5);
    let v2 = v.map(|x| x * x);
    let mut b = [[0.0f64; 8]; 4];
    for c in m.iter().rev() {
        for k in 0..4 {
            for t in 0..8 {
                b[k][t] = b[k][t].mul_add(v2[k], c[t]);
            }
        }
    }
    std::array::from_fn(|k| {
        std::array::from_fn(|t| {
            if t < 4 {
                b[k][t + 4].mul_add(v[k], b[k][t])
            } else {
                (-b[k][11 - t]).mul_add(v[k], b[k][7 - t])
            }
        })
    })
}

/// Spread a batch of leaves (lanes): each live lane's strengths (`sc[c][2 i..2 i + 2]`, real
/// and imaginary) times its kernel weights at offset `u[i]`, from grid index `l0[i]`.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(super) fn spread_lanes(
    plan: &FastPlan,
    grid: &mut [f64],
    u: &[f64; LB],
    l0: &[usize; LB],
    sc: &[[f64; 2 * LB]; MAX_NODES],
    live: &[bool; LB],
) {
    match plan.nufft.w {
        8 => spread_lanes_ws::<8, 16, true>(plan, grid, u, l0, sc, live),
        0..=7 => spread_lanes_ws::<8, 16, false>(plan, grid, u, l0, sc, live),
        _ => spread_lanes_ws::<16, 32, false>(plan, grid, u, l0, sc, live),
    }
}

/// [`spread_lanes`] with `WS` taps (`WS2 = 2 WS` values per channel): the weights of four
/// lanes at a time first (four independent Horner chains), then their spreading.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn spread_lanes_ws<const WS: usize, const WS2: usize, const MIRROR: bool>(
    plan: &FastPlan,
    grid: &mut [f64],
    u: &[f64; LB],
    l0: &[usize; LB],
    sc: &[[f64; 2 * LB]; MAX_NODES],
    live: &[bool; LB],
) {
    const { assert!(!MIRROR || WS == 8) };
    let (p, glen, h) = (plan.p, plan.nufft.grid_len(), &plan.nufft.horner[..]);
    for i0 in (0..LB).step_by(4) {
        let u4 = [u[i0], u[i0 + 1], u[i0 + 2], u[i0 + 3]];
        let a: [[f64; WS]; 4] = if MIRROR {
            let m = weights4_mirror(&plan.nufft.mirror, u4);
            std::array::from_fn(|k| std::array::from_fn(|t| if t < 8 { m[k][t] } else { 0.0 }))
        } else {
            weights4::<WS>(h, u4)
        };
        for (k, w) in a.iter().enumerate() {
            let i = i0 + k;
            if live[i] {
                let w2: [f64; WS2] = std::array::from_fn(|t| w[t / 2]);
                let s = |c: usize| [sc[c][2 * i], sc[c][2 * i + 1]];
                spread_channels(grid, glen, p, l0[i], &w2, s);
            }
        }
    }
}
