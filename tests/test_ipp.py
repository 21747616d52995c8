"""Tests of the inhomogeneous Poisson process sampler (batecho.forest.ipp).

Statistical tests use fixed seeds, so they are deterministic. Each statistical check rejects at
a two-sided significance ALPHA = 1e-4, so a correct sampler fails a given check for a given
seed with probability 1e-4 (at most 2e-4 for the tests that make two checks), well below 1e-3.
Expected counts are computed here independently of the module (closed forms), not with
``integrate_intensity``.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from matplotlib.path import Path
from scipy import integrate, stats
from scipy.special import ndtr

from batecho.forest.ipp import (
    PAPER_WINDOW,
    IPPWarning,
    RasterIntensity,
    SquaredExponentialMixture,
    UniformIntensity,
    draw_tree_positions,
    estimate_lambda_max,
    integrate_intensity,
    paper_intensity,
    sample_ipp,
)

ALPHA = 1e-4  # two-sided significance of every statistical check below
N_DRAWS = 2000  # independent realisations pooled per statistical test

# lambda(x, y) = C exp(x / 2) on [0, 10] x [0, 5] m: intensity varies by e^5 ~ 148 across it.
EXP_C = 0.01
EXP_RECT = (0.0, 10.0, 0.0, 5.0)
EXP_MAX = EXP_C * np.exp(5.0)
# A concave L-shaped polygon inside EXP_RECT: the notch x > 4, y > 2 is cut out.
L_POLYGON = np.array([[0, 0], [10, 0], [10, 2], [4, 2], [4, 5], [0, 5]], dtype=float)


def exp_intensity(x, y):
    return EXP_C * np.exp(np.asarray(x) / 2.0) + 0.0 * np.asarray(y)


def exp_integral(x0: float, x1: float, y0: float, y1: float) -> float:
    """Closed-form integral of C exp(x/2) over a rectangle."""
    return EXP_C * 2.0 * (np.exp(x1 / 2.0) - np.exp(x0 / 2.0)) * (y1 - y0)


EXP_RECT_MEAN = exp_integral(*EXP_RECT)
EXP_L_MEAN = exp_integral(0, 10, 0, 2) + exp_integral(0, 4, 2, 5)


def mixture_cell_integrals(f: SquaredExponentialMixture, xe: np.ndarray, ye: np.ndarray):
    """Closed-form integrals of a Gaussian mixture over the cells of a grid, shape (ny, nx)."""
    out = np.zeros((ye.size - 1, xe.size - 1))
    for (a, b), (lx, ly), w in zip(f.centers, f.length_scales, f.weights, strict=False):
        px = np.diff(ndtr((xe - a) / lx)) * lx * np.sqrt(2 * np.pi)
        py = np.diff(ndtr((ye - b) / ly)) * ly * np.sqrt(2 * np.pi)
        out += w * np.outer(py, px)
    return out


PAPER = paper_intensity()
PAPER_MEAN = mixture_cell_integrals(PAPER, np.array([0.0, 20.0]), np.array([0.0, 20.0])).item()

CASES = {
    # name: (intensity, window, exact lambda_max bound, expected count)
    "paper": (PAPER, PAPER_WINDOW, PAPER.upper_bound(), PAPER_MEAN),
    "exp_rect": (exp_intensity, EXP_RECT, EXP_MAX, EXP_RECT_MEAN),
    "exp_polygon": (exp_intensity, L_POLYGON, EXP_MAX, EXP_L_MEAN),
}


@pytest.fixture(scope="module")
def draws():
    """N_DRAWS realisations per case, each from its own seed."""
    out = {}
    for k, (name, (f, window, lam_max, _)) in enumerate(CASES.items()):
        rng = np.random.default_rng([2024, k])
        out[name] = [sample_ipp(f, window, rng, lambda_max=lam_max) for _ in range(N_DRAWS)]
    return out


def two_sided_chi2_p(statistic: float, df: int) -> float:
    d = stats.chi2(df)
    return min(1.0, 2.0 * min(d.cdf(statistic), d.sf(statistic)))


# ------------------------------------------------------------------ counts are Poisson(∫λ)


@pytest.mark.parametrize("case", list(CASES))
def test_count_mean_matches_integral_of_intensity(draws, case):
    mean = CASES[case][3]
    counts = np.array([len(p) for p in draws[case]])
    z = (counts.mean() - mean) / np.sqrt(mean / counts.size)  # Poisson: var = mean
    assert 2 * stats.norm.sf(abs(z)) > ALPHA, (case, counts.mean(), mean, z)


@pytest.mark.parametrize("case", list(CASES))
def test_count_dispersion_is_poisson(draws, case):
    # Fisher's index of dispersion: sum (N_i - mean)^2 / mean ~ chi2(M - 1) for Poisson counts.
    counts = np.array([len(p) for p in draws[case]])
    d = np.sum((counts - counts.mean()) ** 2) / counts.mean()
    assert two_sided_chi2_p(d, counts.size - 1) > ALPHA, (case, counts.var(), counts.mean())


def test_paper_intensity_expects_five_to_eight_trees():
    assert 5.0 <= PAPER_MEAN <= 8.0
    assert PAPER_WINDOW == (0.0, 20.0, 0.0, 20.0)


# ------------------------------------------------------------------ quadrat chi-square


def pooled_chisquare_p(points: np.ndarray, expected_per_cell: np.ndarray, xe, ye) -> float:
    """Conditional on the pooled total, the cell counts are multinomial with probabilities
    proportional to the integrated intensity; cells expecting < 5 points are merged."""
    obs, _, _ = np.histogram2d(points[:, 1], points[:, 0], bins=[ye, xe])
    obs, p = obs.ravel(), expected_per_cell.ravel() / expected_per_cell.sum()
    exp = p * obs.sum()
    small = exp < 5
    if small.any():
        obs = np.append(obs[~small], obs[small].sum())
        exp = np.append(exp[~small], exp[small].sum())
    return stats.chisquare(obs, exp).pvalue


def test_quadrat_counts_match_paper_intensity(draws):
    xe = ye = np.linspace(0.0, 20.0, 9)  # 8 x 8 cells of 2.5 m
    pts = np.vstack(draws["paper"])
    assert pooled_chisquare_p(pts, mixture_cell_integrals(PAPER, xe, ye), xe, ye) > ALPHA


def test_quadrat_counts_match_exponential_intensity(draws):
    xe, ye = np.linspace(0.0, 10.0, 11), np.linspace(0.0, 5.0, 6)  # 10 x 5 cells of 1 m
    expected = np.array(
        [[exp_integral(xe[j], xe[j + 1], ye[i], ye[i + 1]) for j in range(10)] for i in range(5)]
    )
    pts = np.vstack(draws["exp_rect"])
    assert pooled_chisquare_p(pts, expected, xe, ye) > ALPHA


# ------------------------------------------------------------------ reproducibility


def test_a_uniform_intensity_is_its_density_everywhere_in_the_broadcast_shape():
    lam = UniformIntensity(0.05)
    got = lam(np.zeros((3, 1)), np.arange(4.0))
    assert got.shape == (3, 4)
    assert np.all(got == 0.05)


def test_a_uniform_intensity_draws_what_the_same_constant_function_draws():
    a = sample_ipp(UniformIntensity(0.05), PAPER_WINDOW, np.random.default_rng(4))
    b = sample_ipp(lambda x, y: 0.05, PAPER_WINDOW, np.random.default_rng(4))
    np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("density", [-0.1, float("nan"), float("inf")])
def test_a_uniform_intensity_refuses_a_density_that_is_not_finite_and_nonnegative(density):
    with pytest.raises(ValueError, match="density"):
        UniformIntensity(density)


def test_same_seed_gives_identical_points():
    a = sample_ipp(PAPER, PAPER_WINDOW, np.random.default_rng(7))
    b = sample_ipp(PAPER, PAPER_WINDOW, np.random.default_rng(7))
    assert a.dtype == np.float64 and a.ndim == 2 and a.shape[1] == 2
    np.testing.assert_array_equal(a, b)


def test_different_seeds_give_different_points():
    f = lambda x, y: 0.5
    a = sample_ipp(f, PAPER_WINDOW, np.random.default_rng(1))
    b = sample_ipp(f, PAPER_WINDOW, np.random.default_rng(2))
    assert a.shape != b.shape or not np.array_equal(a, b)


# ------------------------------------------------------------------ points lie in the window


def test_points_lie_inside_rectangle():
    rng = np.random.default_rng(11)
    pts = np.vstack([sample_ipp(exp_intensity, EXP_RECT, rng) for _ in range(20)])
    assert len(pts) > 100
    assert (pts[:, 0] >= 0).all() and (pts[:, 0] <= 10).all()
    assert (pts[:, 1] >= 0).all() and (pts[:, 1] <= 5).all()


@pytest.mark.parametrize("orientation", [1, -1], ids=["counterclockwise", "clockwise"])
def test_points_lie_inside_concave_polygon(orientation):
    rng = np.random.default_rng(12)
    poly = L_POLYGON[::orientation]
    pts = np.vstack([sample_ipp(exp_intensity, poly, rng) for _ in range(20)])
    assert len(pts) > 100
    assert not ((pts[:, 0] > 4) & (pts[:, 1] > 2)).any()  # nothing in the notch
    assert Path(np.vstack([poly, poly[:1]]), closed=True).contains_points(pts).all()


# ------------------------------------------------------------------ lambda_max and IPPWarning


def test_lambda_max_below_true_maximum_warns():
    with pytest.warns(IPPWarning, match="ratio"):
        sample_ipp(exp_intensity, EXP_RECT, np.random.default_rng(3), lambda_max=0.5 * EXP_MAX)


@pytest.mark.parametrize("lam_max", [EXP_MAX, None], ids=["exact", "estimated"])
def test_correct_lambda_max_does_not_warn(lam_max):
    rng = np.random.default_rng(4)
    with warnings.catch_warnings():
        warnings.simplefilter("error", IPPWarning)
        for _ in range(50):
            sample_ipp(exp_intensity, EXP_RECT, rng, lambda_max=lam_max)


def test_estimated_lambda_max_bounds_paper_intensity():
    est = estimate_lambda_max(PAPER, PAPER_WINDOW)
    assert PAPER(6.0, 13.0) <= est <= 1.1 * PAPER.upper_bound()


# ------------------------------------------------------------------ input errors


@pytest.mark.parametrize("bad", [-1.0, np.nan, np.inf], ids=["negative", "nan", "inf"])
def test_invalid_intensity_value_raises_naming_location(bad):
    f = lambda x, y: np.where(x > 15.0, bad, 0.01)
    with pytest.raises(ValueError, match=r"at \(x, y\)"):
        sample_ipp(f, PAPER_WINDOW, np.random.default_rng(0))
    with pytest.raises(ValueError, match=r"at \(x, y\)"):
        sample_ipp(f, PAPER_WINDOW, np.random.default_rng(0), lambda_max=1.0)


@pytest.mark.parametrize(
    "window",
    [
        (1.0, 0.0, 0.0, 1.0),
        (0.0, 0.0, 0.0, 1.0),
        (0.0, 1.0, 2.0, 2.0),
        (0.0, np.nan, 0.0, 1.0),
        (0.0, 1.0, 0.0),
        [[0.0, 0.0], [1.0, 1.0]],
        [[0.0, 0.0], [1.0, 1.0], [2.0, 2.0]],
        [[0.0, 0.0], [1.0, 0.0], [np.inf, 1.0]],
        [[0.0, 0.0], [1.0, 1.0], [0.0, 0.0]],
    ],
    ids=[
        "xmin>xmax",
        "zero-width",
        "zero-height",
        "nan",
        "three-numbers",
        "two-vertices",
        "collinear",
        "infinite-vertex",
        "closed-ring-of-two",
    ],
)
def test_bad_window_raises(window):
    with pytest.raises(ValueError):
        sample_ipp(lambda x, y: 0.1, window, np.random.default_rng(0))


@pytest.mark.parametrize("lam_max", [0.0, -1.0, np.nan, np.inf])
def test_bad_lambda_max_raises(lam_max):
    with pytest.raises(ValueError, match="lambda_max"):
        sample_ipp(lambda x, y: 0.1, PAPER_WINDOW, np.random.default_rng(0), lambda_max=lam_max)


def test_a_legacy_random_state_is_refused_naming_rng():
    with pytest.raises(TypeError, match="rng must be a numpy Generator, an int seed or None"):
        sample_ipp(lambda x, y: 0.1, PAPER_WINDOW, np.random.RandomState(0))


def test_an_int_seed_draws_what_a_generator_of_that_seed_draws():
    a = sample_ipp(paper_intensity(), PAPER_WINDOW, 5)
    b = sample_ipp(paper_intensity(), PAPER_WINDOW, np.random.default_rng(5))
    np.testing.assert_array_equal(a, b)


def test_a_negative_seed_is_refused_naming_rng():
    with pytest.raises(ValueError, match="rng must be a non-negative int seed"):
        sample_ipp(lambda x, y: 0.1, PAPER_WINDOW, -1)


def test_draw_tree_positions_with_an_int_seed_draws_fresh_realisations_each_round():
    # forty trees need several realisations of the paper's intensity (6.6 on average): each
    # must be new, not the seed's first one again
    pts = draw_tree_positions(40, 3)
    assert len(np.unique(pts, axis=0)) == 40


def test_draw_tree_positions_keeps_the_points_of_successive_sample_ipp_rounds_in_order():
    gen = np.random.default_rng(9)
    rounds = []
    while sum(len(r) for r in rounds) < 30:
        rounds.append(sample_ipp(paper_intensity(), PAPER_WINDOW, gen))
    want = np.concatenate(rounds)[:30]
    assert np.array_equal(draw_tree_positions(30, np.random.default_rng(9)), want)


@pytest.mark.parametrize("max_rounds", [0, -1])
def test_draw_tree_positions_refuses_max_rounds_below_one_naming_it(max_rounds):
    with pytest.raises(ValueError, match="max_rounds must be an integer >= 1"):
        draw_tree_positions(3, 1, max_rounds=max_rounds)


def test_draw_tree_positions_refuses_an_intensity_zero_on_the_window_before_drawing():
    with pytest.raises(ValueError, match="zero everywhere on the window"):
        draw_tree_positions(3, 1, lambda x, y: 0.0 * x, max_rounds=5)


def test_draw_tree_positions_refuses_a_count_far_out_of_reach_naming_it_and_the_rate():
    # the paper's intensity gives 6.6 trees a realisation: a million trees in 100,000
    # realisations cannot be drawn, which a thousand realisations show
    with pytest.raises(ValueError, match=r"n_trees = 1000000 is out of reach.* about 6\.\d"):
        draw_tree_positions(10**6, 1)


def test_draw_tree_positions_draws_a_count_that_needs_every_allowed_realisation():
    # 2000 rounds' worth of trees at 6.6 a round, allowed 2500 rounds: drawn, not refused early
    assert len(draw_tree_positions(13_000, 2, max_rounds=2500)) == 13_000


@pytest.mark.parametrize(
    "scalar_only",
    [lambda x, y: 0.1 if x < 5 else 0.0, lambda x, y: 0.1 * math.exp(-x)],
    ids=["if", "math.exp"],
)
def test_an_intensity_written_for_scalars_is_refused_saying_it_must_take_arrays(scalar_only):
    with pytest.raises(
        (TypeError, ValueError), match="intensity must take arrays x, y .* same shape"
    ):
        sample_ipp(scalar_only, PAPER_WINDOW, np.random.default_rng(0))


# ------------------------------------------------------------------ constant and zero intensity


def test_scalar_constant_intensity_works():
    rng = np.random.default_rng(21)
    counts = [sample_ipp(lambda x, y: 0.05, PAPER_WINDOW, rng).shape for _ in range(500)]
    assert all(len(s) == 2 and s[1] == 2 for s in counts)
    n = np.array([s[0] for s in counts])
    z = (n.mean() - 20.0) / np.sqrt(20.0 / n.size)  # 0.05 per m^2 x 400 m^2
    assert 2 * stats.norm.sf(abs(z)) > ALPHA


def test_zero_intensity_gives_empty_array():
    pts = sample_ipp(lambda x, y: 0.0, PAPER_WINDOW, np.random.default_rng(0))
    assert pts.shape == (0, 2) and pts.dtype == np.float64


# ------------------------------------------------------------------ RasterIntensity

RASTER = RasterIntensity(np.array([[0.0, 0.1, 0.2], [0.3, 0.4, 0.5]]), (0.0, 6.0, 0.0, 4.0))


def test_raster_looks_up_cell_values_with_row_zero_at_ymin():
    x = np.array([1.0, 3.0, 5.0, 1.0, 3.0, 5.0, 6.0, 0.0])
    y = np.array([1.0, 1.0, 1.0, 3.0, 3.0, 3.0, 4.0, 0.0])
    np.testing.assert_array_equal(RASTER(x, y), [0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.5, 0.0])


def test_raster_is_zero_outside_extent():
    x = np.array([-0.1, 6.1, 3.0, 3.0, np.nan])
    y = np.array([1.0, 1.0, -0.1, 4.1, 1.0])
    np.testing.assert_array_equal(RASTER(x, y), np.zeros(5))


def test_raster_integral_and_max():
    assert RASTER.max() == 0.5
    assert RASTER.integral() == pytest.approx(1.5 * 4.0)  # cell area 2 m x 2 m
    # clipped to [1, 4] x [0, 3]: overlaps 1, 2, 0 m along x and 2, 1 m along y
    expected = (1 * 2 * 0.0 + 2 * 2 * 0.1 + 0 * 0.2) + (1 * 1 * 0.3 + 2 * 1 * 0.4)
    assert RASTER.integral((1.0, 4.0, 0.0, 3.0)) == pytest.approx(expected)


@pytest.mark.parametrize("values", [[[0.1, -0.1]], [[0.1, np.nan]], [[np.inf]]])
def test_raster_rejects_negative_or_non_finite_values(values):
    with pytest.raises(ValueError):
        RasterIntensity(values, (0.0, 1.0, 0.0, 1.0))


def test_sampling_raster_matches_integral_in_mean():
    rng = np.random.default_rng(31)
    counts = np.array([len(sample_ipp(RASTER, (0.0, 6.0, 0.0, 4.0), rng)) for _ in range(2000)])
    mean = 6.0
    z = (counts.mean() - mean) / np.sqrt(mean / counts.size)
    assert 2 * stats.norm.sf(abs(z)) > ALPHA


# ------------------------------------------------------------------ integrate_intensity


def test_integrate_intensity_matches_closed_forms():
    assert integrate_intensity(exp_intensity, EXP_RECT) == pytest.approx(EXP_RECT_MEAN, rel=1e-5)
    assert integrate_intensity(exp_intensity, L_POLYGON) == pytest.approx(EXP_L_MEAN, rel=1e-4)
    assert integrate_intensity(PAPER, PAPER_WINDOW) == pytest.approx(PAPER_MEAN, rel=1e-12)
    numeric = integrate_intensity(lambda x, y: PAPER(x, y), PAPER_WINDOW)
    assert numeric == pytest.approx(PAPER_MEAN, rel=1e-5)


def test_integrate_intensity_on_triangle_agrees_with_dblquad():
    tri = np.array([[0.0, 0.0], [20.0, 0.0], [0.0, 20.0]])  # hypotenuse on sample diagonals
    ref, _ = integrate.dblquad(lambda y, x: float(PAPER(x, y)), 0.0, 20.0, 0.0, lambda x: 20 - x)
    assert integrate_intensity(PAPER, tri) == pytest.approx(ref, rel=1e-4)


def test_mixture_integral_agrees_with_dblquad():
    f = SquaredExponentialMixture([[1.0, 2.0]], [[0.7, 1.5]], [0.3])
    ref, _ = integrate.dblquad(lambda y, x: float(f(x, y)), -1.0, 2.0, 0.0, 5.0)
    assert f.integral((-1.0, 2.0, 0.0, 5.0)) == pytest.approx(ref, rel=1e-8)
    assert f.integral() == pytest.approx(0.3 * 2 * np.pi * 0.7 * 1.5)


@pytest.fixture
def one_mib_limit():
    import batecho

    before = batecho.set_memory_limit(2**20)
    yield
    batecho.set_memory_limit(before)


@pytest.mark.usefixtures("one_mib_limit")
def test_integrate_intensity_refuses_a_grid_too_large_for_memory_naming_n():
    with pytest.raises(MemoryError, match="n = 400"):
        integrate_intensity(exp_intensity, EXP_RECT, n=400)


@pytest.mark.usefixtures("one_mib_limit")
def test_integrate_intensity_refuses_a_boundary_refinement_too_large_for_memory_naming_it():
    with pytest.raises(MemoryError, match="refine = 100000"):
        integrate_intensity(exp_intensity, L_POLYGON, n=16, refine=100_000)


@pytest.mark.usefixtures("one_mib_limit")
def test_estimate_lambda_max_refuses_a_grid_too_large_for_memory_naming_n():
    with pytest.raises(MemoryError, match="n = 400"):
        estimate_lambda_max(exp_intensity, EXP_RECT, n=400)


@pytest.mark.parametrize("scale", [1e8, 1e16, 1e200])
def test_mixture_integral_of_a_bump_far_wider_than_the_window_is_its_peak_times_the_area(scale):
    f = SquaredExponentialMixture([[0.0, 0.0]], [scale], [0.5])
    assert f.integral((0.0, 2.0, -1.0, 2.0)) == pytest.approx(0.5 * 2.0 * 3.0, rel=1e-9)


def test_mixture_integral_far_out_in_a_tail_keeps_its_relative_precision():
    f = SquaredExponentialMixture([[0.0, 0.0]], [1.0], [1.0])
    x0, x1 = 10.0, 11.0  # Phi(x1) - Phi(x0) is ~7.6e-24: it cancels to 0 near 1
    expected = 2.0 * np.pi * (ndtr(-x0) - ndtr(-x1)) * (ndtr(1.0) - ndtr(-1.0))
    assert f.integral((x0, x1, -1.0, 1.0)) == pytest.approx(expected, rel=1e-12, abs=0.0)


@pytest.mark.parametrize(
    "window",
    [(-1e308, 1e308, 0.0, 1.0), (0.0, 1e200, 0.0, 1e200), [[-1e308, 0], [1e308, 0], [0, 1]]],
)
def test_a_window_whose_size_overflows_float64_is_refused_naming_the_window(window):
    with pytest.raises(ValueError, match="window .*float64"):
        sample_ipp(paper_intensity(), window, 0)


@pytest.mark.parametrize("lam_max", [True, "0.1"])
def test_a_lambda_max_that_is_not_a_number_is_refused_naming_it(lam_max):
    with pytest.raises(TypeError, match="lambda_max"):
        sample_ipp(paper_intensity(), PAPER_WINDOW, 0, lambda_max=lam_max)


@pytest.mark.usefixtures("one_mib_limit")
def test_sample_ipp_refuses_candidates_too_many_for_the_memory_limit_before_drawing():
    with pytest.raises(MemoryError, match="candidate points .*lambda_max 1 per m\\^2"):
        sample_ipp(UniformIntensity(1.0), (0.0, 1e3, 0.0, 1e3), 0, lambda_max=1.0)


@pytest.mark.usefixtures("one_mib_limit")
def test_draw_tree_positions_refuses_trees_too_many_for_the_memory_limit_naming_n_trees():
    with pytest.raises(MemoryError, match="n_trees = 100000"):
        draw_tree_positions(100_000, 0, UniformIntensity(1.0), (0.0, 100.0, 0.0, 100.0))
