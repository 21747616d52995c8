"""Tree positions as an inhomogeneous Poisson process (IPP) on a 2-D window, by thinning.

Tanveer et al. ("Recreating bat behavior on quad-rotor UAVs") place trees at the points of an
IPP with a user intensity lambda(s) (points per m^2) on a region D of the ground plane. Given
D and lambda, the number of trees is Poisson with mean the integral of lambda over D, and the
positions are drawn by thinning (Lewis & Shedler 1979): a homogeneous Poisson process of rate
``lambda_max`` on the bounding box of D, each point kept with probability
``lambda(s) / lambda_max`` and only if it lies in D.

Units: metres for coordinates, points (trees) per m^2 for intensities.
"""

from __future__ import annotations

import math
import re
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from .._pickle import ReadOnlyOnLoading
from .._random import generator
from .._resources import check_memory
from .._validate import finite, integer, positive_scalar, real_array

__all__ = [
    "DEFAULT_GRID",
    "DEFAULT_SAFETY_MARGIN",
    "MAX_CANDIDATES",
    "PAPER_WINDOW",
    "IPPWarning",
    "RasterIntensity",
    "SquaredExponentialMixture",
    "UniformIntensity",
    "draw_tree_positions",
    "estimate_lambda_max",
    "integrate_intensity",
    "paper_intensity",
    "sample_ipp",
]

#: Factor applied to the largest intensity seen on the estimation grid to get ``lambda_max``.
DEFAULT_SAFETY_MARGIN = 1.1
#: Points per side of the grid on which ``lambda_max`` is estimated (plus the window vertices).
DEFAULT_GRID = 256
#: Refuse to draw more candidate points than this on average.
MAX_CANDIDATES = 50_000_000
#: Memory per candidate point of :func:`sample_ipp` (bytes): its three uniforms, coordinates,
#: membership masks, indices and intensity (about 1 GB per 1e7 candidates, as measured).
BYTES_PER_CANDIDATE = 96.0
#: Memory per grid point or boundary sample of :func:`integrate_intensity` and
#: :func:`estimate_lambda_max` (bytes): the coordinates, their stacked copies, the membership
#: masks and the intensity's value (a function's own temporaries come on top).
BYTES_PER_GRID_POINT = 64.0
#: The paper's 20 m x 20 m field ``(xmin, xmax, ymin, ymax)``, m.
PAPER_WINDOW: tuple[float, float, float, float] = (0.0, 20.0, 0.0, 20.0)

#: An intensity: ``f(x, y) -> points per m^2`` on NumPy arrays (or a :class:`RasterIntensity`).
Intensity = Callable[[np.ndarray, np.ndarray], Any]

# What NumPy and Python say when a function written for scalars is called on arrays.
_NOT_VECTORISED = re.compile(
    r"truth value of an array|only (length-1|0-dimensional|integer scalar) arrays? can be"
)


class IPPWarning(UserWarning):
    """The intensity exceeded ``lambda_max`` at a candidate point: thinning is biased there."""


# --------------------------------------------------------------------------------------------
# Windows
# --------------------------------------------------------------------------------------------


class _Window:
    """A validated rectangle or simple polygon: bounding box, area (m^2), membership test."""

    __slots__ = ("_path", "area", "bbox", "vertices")

    def __init__(self, window: Any):
        arr = real_array(window, "window")
        if arr.ndim == 1:
            if arr.shape != (4,):
                raise ValueError(
                    "window must be (xmin, xmax, ymin, ymax) or a (k, 2) array of polygon "
                    f"vertices; got shape {arr.shape}"
                )
            finite(arr, "window")
            xmin, xmax, ymin, ymax = (float(v) for v in arr)
            if not (xmin < xmax and ymin < ymax):
                raise ValueError(
                    "window (xmin, xmax, ymin, ymax) needs xmin < xmax and ymin < ymax; got "
                    f"{tuple(arr.tolist())}"
                )
            self.bbox = (xmin, xmax, ymin, ymax)
            self.area = _box_area(self.bbox, "window")
            self.vertices = np.array(
                [[xmin, ymin], [xmax, ymin], [xmax, ymax], [xmin, ymax]], dtype=np.float64
            )
            self._path = None
            return
        if arr.ndim != 2 or arr.shape[1] != 2:
            raise ValueError(
                f"a polygon window must be a (k, 2) array of vertices (m); got shape {arr.shape}"
            )
        finite(arr, "window vertices")
        if arr.shape[0] >= 2 and np.array_equal(arr[0], arr[-1]):
            arr = arr[:-1]  # an explicitly closed ring: drop the repeated vertex
        if arr.shape[0] < 3:
            raise ValueError(f"a polygon window needs at least 3 vertices; got {arr.shape[0]}")
        x, y = arr[:, 0], arr[:, 1]
        xmin, xmax, ymin, ymax = float(x.min()), float(x.max()), float(y.min()), float(y.max())
        _box_area((xmin, xmax, ymin, ymax), "polygon window")
        # Shoelace formula; |area| so that either orientation is accepted.
        area = 0.5 * abs(float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y)))
        if not (xmin < xmax and ymin < ymax) or area <= 1e-12 * (xmax - xmin) * (ymax - ymin):
            raise ValueError(f"polygon window has zero area (vertices {arr.tolist()})")
        self.bbox = (xmin, xmax, ymin, ymax)
        self.area = area
        self.vertices = arr
        from matplotlib.path import Path

        self._path = Path(np.vstack([arr, arr[:1]]), closed=True)

    @property
    def is_rectangle(self) -> bool:
        return self._path is None

    def contains(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Boolean mask of the points (x, y) (m) that lie in the window."""
        if self._path is None:
            xmin, xmax, ymin, ymax = self.bbox
            return (x >= xmin) & (x <= xmax) & (y >= ymin) & (y <= ymax)
        if x.size == 0:
            return np.zeros(x.shape, dtype=bool)
        return self._path.contains_points(np.column_stack([x.ravel(), y.ravel()])).reshape(x.shape)


def _box_area(bbox: tuple[float, float, float, float], what: str) -> float:
    """The area (m^2) of the box ``bbox``; ValueError naming ``what`` when its sides or area
    overflow float64 (grids on it would be NaN)."""
    xmin, xmax, ymin, ymax = bbox
    with np.errstate(over="ignore"):
        area = (xmax - xmin) * (ymax - ymin)
    if not math.isfinite(area):
        raise ValueError(
            f"{what} spans {xmax - xmin:.3g} m x {ymax - ymin:.3g} m, whose area is beyond "
            "float64; use a window of ordinary size"
        )
    return area


#: A window: ``(xmin, xmax, ymin, ymax)`` in m, or a (k, 2) array of polygon vertices in m
#: (or one already checked).
Window = tuple[float, float, float, float] | np.ndarray | _Window


def _as_window(window: Any) -> _Window:
    return window if isinstance(window, _Window) else _Window(window)


# --------------------------------------------------------------------------------------------
# Intensities
# --------------------------------------------------------------------------------------------


def _evaluate(intensity: Any, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """lambda(x, y) as float64 of x's shape; ValueError naming the first bad location."""
    if not callable(intensity):
        raise TypeError(
            "intensity must be a callable f(x, y) -> points per m^2 (or a RasterIntensity); "
            f"got {type(intensity).__name__}"
        )
    try:
        raw = np.asarray(intensity(x, y))
    except (TypeError, ValueError) as exc:
        if not _NOT_VECTORISED.search(str(exc)):
            raise
        # A function written for scalars (``if x < 5``, ``math.exp(x)``) fails deep inside
        # NumPy; say what the intensity must be instead.
        raise type(exc)(
            "intensity must take arrays x, y (m) and return an array of the same shape "
            f"(points per m^2), e.g. with np.where instead of if; calling it on arrays raised: "
            f"{exc}"
        ) from exc
    if raw.dtype.kind not in "biuf":
        raise TypeError(f"intensity must return real numbers; got dtype {raw.dtype}")
    try:
        lam = np.broadcast_to(raw.astype(np.float64, copy=False), x.shape)
    except ValueError:
        raise ValueError(
            f"intensity returned shape {raw.shape}, which does not broadcast to the shape "
            f"{x.shape} of its inputs; it must be vectorised"
        ) from None
    bad = ~(lam >= 0) | ~np.isfinite(lam)  # catches NaN, negative and infinite
    if bad.any():
        i = int(np.flatnonzero(bad.ravel())[0])
        raise ValueError(
            "intensity must be finite and >= 0 points per m^2; at (x, y) = "
            f"({x.ravel()[i]:.6g}, {y.ravel()[i]:.6g}) m it is {float(lam.ravel()[i])!r}"
        )
    return lam


@dataclass(frozen=True)
class UniformIntensity:
    """The same intensity everywhere, ``density`` points per m^2 (finite, >= 0): a homogeneous
    Poisson process. Unlike ``lambda x, y: density``, it pickles, and so does a forest drawn
    with it."""

    density: float

    def __post_init__(self):
        d = positive_scalar(self.density, "density", allow_zero=True, strict=True, unit="per m^2")
        object.__setattr__(self, "density", d)

    def __call__(self, x: Any, y: Any) -> np.ndarray:
        """``density`` at (x, y) (m), in the broadcast shape of ``x`` and ``y``."""
        return np.full(np.broadcast(x, y).shape, self.density)


class RasterIntensity(ReadOnlyOnLoading):
    """A gridded, piecewise-constant intensity (points per m^2).

    Parameters
    ----------
    values : array_like, shape (ny, nx)
        Intensity of each cell, points per m^2, finite and >= 0. Row ``i`` covers
        ``y`` in ``[ymin + i dy, ymin + (i + 1) dy)`` -- row 0 is at ``ymin`` (as
        ``imshow(origin="lower")``); flip a top-down image with ``np.flipud`` first.
    extent : (xmin, xmax, ymin, ymax)
        Outer cell edges of the raster, m.

    Notes
    -----
    Calling it as ``f(x, y)`` looks up the cell of each point; points outside the extent get 0.
    The outer edges ``x = xmax`` and ``y = ymax`` belong to the last column / row.
    """

    __slots__ = ("_extent", "_values", "_x_edges", "_y_edges")

    def __init__(self, values: Any, extent: Any):
        v = real_array(values, "values")
        if v.ndim != 2 or v.shape[0] < 1 or v.shape[1] < 1:
            raise ValueError(f"values must be a non-empty (ny, nx) array; got shape {v.shape}")
        finite(v, "values")
        if (v < 0).any():
            i, j = (int(k) for k in np.argwhere(v < 0)[0])
            raise ValueError(f"values must be >= 0 points per m^2; values[{i}, {j}] is {v[i, j]}")
        ext = real_array(extent, "extent")
        if ext.shape != (4,):
            raise ValueError(f"extent must be (xmin, xmax, ymin, ymax); got shape {ext.shape}")
        finite(ext, "extent")
        xmin, xmax, ymin, ymax = (float(e) for e in ext)
        if not (xmin < xmax and ymin < ymax):
            raise ValueError(f"extent needs xmin < xmax and ymin < ymax; got {tuple(ext)}")
        v.setflags(write=False)
        self._values = v
        self._extent = (xmin, xmax, ymin, ymax)
        self._x_edges = np.linspace(xmin, xmax, v.shape[1] + 1)
        self._y_edges = np.linspace(ymin, ymax, v.shape[0] + 1)
        self._x_edges.setflags(write=False)
        self._y_edges.setflags(write=False)

    @property
    def values(self) -> np.ndarray:
        """(ny, nx) cell intensities, points per m^2 (read-only)."""
        return self._values

    @property
    def extent(self) -> tuple[float, float, float, float]:
        """(xmin, xmax, ymin, ymax) of the outer cell edges, m."""
        return self._extent

    @property
    def x_edges(self) -> np.ndarray:
        """(nx + 1,) cell edges along x, m (read-only)."""
        return self._x_edges

    @property
    def y_edges(self) -> np.ndarray:
        """(ny + 1,) cell edges along y, m (read-only)."""
        return self._y_edges

    @property
    def cell_area(self) -> float:
        """Area of one cell, m^2."""
        return float((self._x_edges[1] - self._x_edges[0]) * (self._y_edges[1] - self._y_edges[0]))

    def __call__(self, x: Any, y: Any) -> np.ndarray:
        """Intensity at (x, y) (m), points per m^2; 0 outside the extent."""
        x, y = np.broadcast_arrays(np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64))
        xmin, xmax, ymin, ymax = self._extent
        inside = (x >= xmin) & (x <= xmax) & (y >= ymin) & (y <= ymax)
        ny, nx = self._values.shape
        j = np.minimum(np.searchsorted(self._x_edges, x[inside], side="right") - 1, nx - 1)
        i = np.minimum(np.searchsorted(self._y_edges, y[inside], side="right") - 1, ny - 1)
        out = np.zeros(x.shape, dtype=np.float64)
        out[inside] = self._values[i, j]
        return out

    def max(self) -> float:
        """Largest cell intensity, points per m^2."""
        return float(self._values.max())

    def _max_in_box(self, bbox: tuple[float, float, float, float]) -> float:
        """Largest intensity over the cells that meet the box (0 if none), points per m^2."""
        ox, oy = self._overlaps(bbox, closed=True)
        sub = self._values[np.ix_(oy, ox)]
        return float(sub.max()) if sub.size else 0.0

    def _overlaps(self, bbox: tuple[float, float, float, float], closed: bool = False):
        xmin, xmax, ymin, ymax = bbox
        xe, ye = self._x_edges, self._y_edges
        lx = np.minimum(xe[1:], xmax) - np.maximum(xe[:-1], xmin)
        ly = np.minimum(ye[1:], ymax) - np.maximum(ye[:-1], ymin)
        if closed:  # which cells the closed box touches
            return lx >= 0, ly >= 0
        return np.clip(lx, 0.0, None), np.clip(ly, 0.0, None)

    def integral(self, window: Window | None = None) -> float:
        """Expected number of points, the integral of the raster over ``window`` (default: its
        extent). Exact for a rectangular window (cell areas clipped to it); a polygon window
        uses :func:`integrate_intensity`'s midpoint rule."""
        if window is None:
            return float(self._values.sum()) * self.cell_area
        w = _as_window(window)
        if not w.is_rectangle:
            return integrate_intensity(self, w)
        lx, ly = self._overlaps(w.bbox)
        return float(ly @ self._values @ lx)

    def __repr__(self) -> str:
        ny, nx = self._values.shape
        return f"RasterIntensity(shape=({ny}, {nx}), extent={self._extent})"


def _per_component(a: np.ndarray, k: int, name: str) -> np.ndarray:
    if a.ndim == 0:
        a = np.full(k, float(a))
    if a.ndim == 1 and a.shape[0] == k:
        a = np.column_stack([a, a])
    if a.shape != (k, 2):
        raise ValueError(f"{name} must have shape ({k},) or ({k}, 2); got {a.shape}")
    return a


@dataclass(frozen=True, eq=False)
class SquaredExponentialMixture(ReadOnlyOnLoading):
    """A mixture of squared-exponential (Gaussian-shaped) bumps, points per m^2::

        lambda(x, y) = sum_j w_j exp(-(x - a_j)^2 / (2 lx_j^2) - (y - b_j)^2 / (2 ly_j^2))

    Parameters
    ----------
    centers : array_like, shape (k, 2)
        Bump centres ``(a_j, b_j)``, m.
    length_scales : array_like, shape (k,) or (k, 2)
        Standard deviations ``l_j`` (isotropic) or ``(lx_j, ly_j)`` (per axis, as the paper's
        ``(h_i, l_i)``), m, > 0.
    weights : array_like, shape (k,)
        Peak intensity ``w_j`` of each bump, points per m^2, >= 0.

    Notes
    -----
    Vectorised: ``f(x, y)`` takes arrays of any (broadcastable) shape. The fields are stored
    as read-only float64 arrays; ``length_scales`` always as (k, 2).
    """

    centers: np.ndarray
    length_scales: np.ndarray
    weights: np.ndarray

    def __post_init__(self) -> None:
        c = real_array(self.centers, "centers")
        if c.ndim == 1 and c.shape == (2,):
            c = c[None, :]
        if c.ndim != 2 or c.shape[1] != 2 or c.shape[0] < 1:
            raise ValueError(f"centers must have shape (k, 2) with k >= 1; got {c.shape}")
        k = c.shape[0]
        finite(c, "centers")
        ls = _per_component(real_array(self.length_scales, "length_scales"), k, "length_scales")
        finite(ls, "length_scales")
        if not (ls > 0).all():
            raise ValueError(f"length_scales must be > 0 m; got {ls.tolist()}")
        w = real_array(self.weights, "weights")
        if w.ndim == 0:
            w = np.full(k, float(w))
        if w.shape != (k,):
            raise ValueError(f"weights must have shape ({k},); got {w.shape}")
        finite(w, "weights")
        if (w < 0).any():
            raise ValueError(f"weights must be >= 0 points per m^2; got {w.tolist()}")
        for name, arr in (("centers", c), ("length_scales", ls), ("weights", w)):
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)

    def __call__(self, x: Any, y: Any) -> np.ndarray:
        """Intensity at (x, y) (m), points per m^2."""
        x = np.asarray(x, dtype=np.float64)[..., None]
        y = np.asarray(y, dtype=np.float64)[..., None]
        u = (x - self.centers[:, 0]) / self.length_scales[:, 0]
        v = (y - self.centers[:, 1]) / self.length_scales[:, 1]
        return np.exp(-0.5 * (u * u + v * v)) @ self.weights

    def upper_bound(self) -> float:
        """``sum_j w_j``, an upper bound of the intensity everywhere, points per m^2."""
        return float(self.weights.sum())

    def integral(self, window: Window | None = None) -> float:
        """Expected number of points: the integral over ``window`` (default: the whole plane).
        Exact (via the normal CDF) for a rectangle; a polygon uses :func:`integrate_intensity`."""
        lx, ly = self.length_scales[:, 0], self.length_scales[:, 1]
        if window is None:
            return float(np.sum(self.weights * 2.0 * np.pi * lx * ly))
        w = _as_window(window)
        if not w.is_rectangle:
            return integrate_intensity(self, w)
        xmin, xmax, ymin, ymax = w.bbox
        a, b = self.centers[:, 0], self.centers[:, 1]
        # each axis's integral, sqrt(2 pi) l (Phi(u1) - Phi(u0)), kept apart: their product
        # with the weight is finite where 2 pi lx ly alone overflows (a bump far wider than
        # the window)
        ix = lx * _normal_mass((xmin - a) / lx, (xmax - a) / lx)
        iy = ly * _normal_mass((ymin - b) / ly, (ymax - b) / ly)
        return float(np.sum(self.weights * ix * iy))

    def _peaks_in_box(self, bbox: tuple[float, float, float, float]) -> np.ndarray:
        """Each bump's maximiser over the box (its centre clipped to it), (k, 2) m."""
        xmin, xmax, ymin, ymax = bbox
        return np.column_stack(
            [np.clip(self.centers[:, 0], xmin, xmax), np.clip(self.centers[:, 1], ymin, ymax)]
        )


def _normal_mass(u0: np.ndarray, u1: np.ndarray) -> np.ndarray:
    """``sqrt(2 pi) (Phi(u1) - Phi(u0))`` for ``u0 <= u1``, to a few ulp relative: from erf
    near 0 (``Phi`` is near 1/2 there, and its difference would cancel) and from erfc in
    either tail (near 0 or 1)."""
    from scipy.special import erf, erfc

    r = 1.0 / math.sqrt(2.0)
    s0, s1 = u0 * r, u1 * r
    with np.errstate(invalid="ignore"):
        upper = erfc(s0) - erfc(s1)  # both in the upper tail
        lower = erfc(-s1) - erfc(-s0)  # both in the lower tail
        middle = erf(s1) - erf(s0)
    d = np.where(s0 >= 1.0, upper, np.where(s1 <= -1.0, lower, middle))
    return math.sqrt(0.5 * math.pi) * d


def paper_intensity() -> SquaredExponentialMixture:
    """The example intensity for the paper's 20 m x 20 m field :data:`PAPER_WINDOW`::

        lambda(s) = 0.06 exp(-|s - (6, 13)|^2 / (2 * 2.5^2))
                  + 0.06 exp(-|s - (14, 6)|^2 / (2 * 3.5^2))      points per m^2, s in m

    Two clumps of trees, a tight one up-left and a wider one down-right, with sparse ground
    between them. The integral over the field is about 6.6 trees (peak about 0.06 per m^2).
    """
    return SquaredExponentialMixture(
        centers=np.array([[6.0, 13.0], [14.0, 6.0]]),
        length_scales=np.array([2.5, 3.5]),
        weights=np.array([0.06, 0.06]),
    )


# --------------------------------------------------------------------------------------------
# Integration, lambda_max, sampling
# --------------------------------------------------------------------------------------------


def _lattice(n: int) -> tuple[np.ndarray, np.ndarray]:
    """A rank-1 (Fibonacci-type) lattice of ``n`` points in the unit square: evenly spread in
    every direction, so no polygon edge can pass through a whole row of them."""
    k = np.arange(n)
    g = max(1, round(n / ((1.0 + 5.0**0.5) / 2.0)))
    return (k + 0.5) / n, ((k * g) % n + 0.5) / n


def integrate_intensity(
    intensity: Intensity, window: Window, n: int = 512, refine: int = 233
) -> float:
    """Expected number of points in ``window``: the integral of ``intensity`` over it.

    A :class:`RasterIntensity` or :class:`SquaredExponentialMixture` on a rectangular window is
    integrated exactly. Otherwise the midpoint rule on an ``n`` x ``n`` grid of cells over the
    window's bounding box (error O(h^2) for smooth intensities, h = box side / n). For a
    polygon, the cells the boundary crosses (their corners or midpoint disagree on membership)
    are instead sampled at ``refine`` points of a Fibonacci lattice, those in the window
    counted; this shrinks the O(h) boundary error to about h / refine along axis-parallel
    edges and h / sqrt(refine) along others (relative error ~1e-5 with the defaults). A grid
    or refinement too large for :func:`batecho.memory_limit` raises MemoryError naming ``n``
    or ``refine`` before it is built.
    """
    w = _as_window(window)
    if w.is_rectangle and isinstance(intensity, (RasterIntensity, SquaredExponentialMixture)):
        return intensity.integral(w)
    for name, v in (("n", n), ("refine", refine)):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 1:
            raise ValueError(f"{name} must be a positive integer; got {v!r}")
    check_memory(
        (n + 1.0) ** 2 * BYTES_PER_GRID_POINT,
        f"integrate_intensity on an n x n grid of n = {n}",
        "use a smaller n",
    )
    xmin, xmax, ymin, ymax = w.bbox
    hx, hy = (xmax - xmin) / n, (ymax - ymin) / n
    gx, gy = np.meshgrid(xmin + hx * (np.arange(n) + 0.5), ymin + hy * (np.arange(n) + 0.5))
    if w.is_rectangle:
        return float(_evaluate(intensity, gx, gy).sum()) * hx * hy
    mid_in = w.contains(gx, gy)
    ex, ey = np.meshgrid(np.linspace(xmin, xmax, n + 1), np.linspace(ymin, ymax, n + 1))
    c = w.contains(ex, ey).astype(np.int8)
    corners = c[:-1, :-1] + c[:-1, 1:] + c[1:, :-1] + c[1:, 1:]
    interior = (corners == 4) & mid_in
    cut = ~interior & ((corners > 0) | mid_in)
    total = float(_evaluate(intensity, gx[interior], gy[interior]).sum()) * hx * hy
    iy, ix = np.nonzero(cut)
    check_memory(
        float(iy.size) * refine * BYTES_PER_GRID_POINT,
        f"integrate_intensity's refine = {refine} samples in each of the {iy.size} cells the "
        "window's boundary crosses",
        "use a smaller refine (or n)",
    )
    if iy.size:
        ox, oy = _lattice(int(refine))
        sx = (xmin + hx * (ix[:, None] + ox)).ravel()
        sy = (ymin + hy * (iy[:, None] + oy)).ravel()
        keep = w.contains(sx, sy)
        total += float(_evaluate(intensity, sx[keep], sy[keep]).sum()) * hx * hy / refine
    return total


def estimate_lambda_max(
    intensity: Intensity,
    window: Window,
    n: int = DEFAULT_GRID,
    margin: float = DEFAULT_SAFETY_MARGIN,
) -> float:
    """An estimate of ``max lambda`` over the window's bounding box, points per m^2.

    ``margin`` (default 1.1) times the largest ``lambda`` on an ``n`` x ``n`` grid spanning the
    bounding box plus the window's vertices (and, for a :class:`SquaredExponentialMixture`, each
    bump's maximiser in the box). For a :class:`RasterIntensity` it is the exact largest cell
    value meeting the box, without margin. Returns 0 if every evaluated value is 0.
    Raises ValueError where ``lambda`` is negative, NaN or infinite, and MemoryError naming
    ``n`` for a grid too large for :func:`batecho.memory_limit`.
    """
    w = _as_window(window)
    if isinstance(intensity, RasterIntensity):
        return intensity._max_in_box(w.bbox)
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 2:
        raise ValueError(f"n must be an integer >= 2; got {n!r}")
    m = float(margin)
    if not (np.isfinite(m) and m >= 1.0):
        raise ValueError(f"margin must be finite and >= 1; got {margin!r}")
    check_memory(
        float(n) * n * BYTES_PER_GRID_POINT,
        f"estimate_lambda_max on an n x n grid of n = {n}",
        "use a smaller n",
    )
    xmin, xmax, ymin, ymax = w.bbox
    gx, gy = np.meshgrid(np.linspace(xmin, xmax, n), np.linspace(ymin, ymax, n))
    pts = [np.column_stack([gx.ravel(), gy.ravel()]), w.vertices]
    if isinstance(intensity, SquaredExponentialMixture):
        pts.append(intensity._peaks_in_box(w.bbox))
    xy = np.vstack(pts)
    lam = _evaluate(intensity, xy[:, 0], xy[:, 1])
    return m * float(lam.max())


def sample_ipp(
    intensity: Intensity,
    window: Window,
    rng: np.random.Generator | int | None,
    lambda_max: float | None = None,
) -> np.ndarray:
    """Draw one realisation of the IPP with intensity ``lambda`` on ``window``, by thinning.

    Parameters
    ----------
    intensity : callable or RasterIntensity
        Vectorised ``f(x, y)`` on NumPy arrays (m) returning points per m^2, >= 0 and finite;
        a scalar return value is broadcast (``lambda x, y: 0.05`` is a homogeneous process, as is
        ``UniformIntensity(0.05)``, which pickles).
    window : (xmin, xmax, ymin, ymax) or array_like (k, 2)
        A rectangle, or the vertices of a simple polygon (either orientation), m.
    rng : numpy.random.Generator, int or None
        The source of randomness: a Generator (its stream continues), or an int seed (the same
        points as ``np.random.default_rng(seed)``), or None (fresh entropy).
    lambda_max : float, optional
        An upper bound of ``lambda`` on the window's bounding box, points per m^2. If omitted it
        is estimated by :func:`estimate_lambda_max` (grid maximum times 1.1).

    Returns
    -------
    (n, 2) float64 array of the points (m) in the window, in the order drawn; (0, 2) if
    ``lambda`` is identically zero.

    Candidates are a homogeneous Poisson process of rate ``lambda_max`` on the bounding box;
    each is kept if it lies in the window and ``U * lambda_max < lambda(s)`` with ``U`` uniform
    on [0, 1). ``lambda`` is evaluated only at candidates inside the window (and, when
    estimating ``lambda_max``, on the grid). Warns :class:`IPPWarning` if ``lambda`` exceeds
    ``lambda_max`` at a candidate: the sample then under-represents those places.
    """
    gen = generator(rng)
    if not callable(intensity):
        raise TypeError(
            "intensity must be a callable f(x, y) -> points per m^2 (or a RasterIntensity); "
            f"got {type(intensity).__name__}"
        )
    w = _as_window(window)
    if lambda_max is None:
        lam_max = estimate_lambda_max(intensity, w)
        if lam_max == 0.0:
            return np.empty((0, 2), dtype=np.float64)
    else:
        lam_max = positive_scalar(lambda_max, "lambda_max", strict=True, unit="points per m^2")
    xmin, xmax, ymin, ymax = w.bbox
    expected = lam_max * (xmax - xmin) * (ymax - ymin)
    if expected > MAX_CANDIDATES:
        raise ValueError(
            f"lambda_max {lam_max:g} per m^2 on a {xmax - xmin:g} m x {ymax - ymin:g} m box "
            f"means ~{expected:.3g} candidate points (limit {MAX_CANDIDATES:.3g}); "
            "use a smaller window or a tighter lambda_max"
        )
    check_memory(
        expected * BYTES_PER_CANDIDATE,
        f"sample_ipp's ~{expected:.3g} candidate points (lambda_max {lam_max:g} per m^2 on a "
        f"{xmax - xmin:g} m x {ymax - ymin:g} m box)",
        "use a smaller window or a tighter lambda_max",
    )
    n = int(gen.poisson(expected))
    u = gen.random((n, 3))
    x = xmin + (xmax - xmin) * u[:, 0]
    y = ymin + (ymax - ymin) * u[:, 1]
    inside = np.flatnonzero(w.contains(x, y))
    lam = _evaluate(intensity, x[inside], y[inside])
    if lam.size and lam.max() > lam_max:
        k = int(np.argmax(lam))
        warnings.warn(
            f"the intensity exceeds lambda_max = {lam_max:.6g} per m^2 at candidate points "
            f"(largest ratio lambda / lambda_max = {lam[k] / lam_max:.4g}, at (x, y) = "
            f"({x[inside[k]]:.6g}, {y[inside[k]]:.6g}) m); thinning is biased there (too few "
            "points). Pass a larger lambda_max.",
            IPPWarning,
            stacklevel=2,
        )
    keep = inside[u[inside, 2] * lam_max < lam]
    return np.column_stack([x[keep], y[keep]])


def draw_tree_positions(
    n_trees: int,
    rng: np.random.Generator | int | None,
    intensity: Any = None,
    window: Any = PAPER_WINDOW,
    max_rounds: int = 100_000,
) -> np.ndarray:
    """``n_trees`` tree positions (n, 2) m from the IPP conditioned on having ``n_trees`` points.

    Draws IPP realisations by thinning (:func:`sample_ipp`, default intensity
    :func:`paper_intensity` on :data:`PAPER_WINDOW`) and keeps the points in the
    order drawn until there are ``n_trees``. Given its count, an IPP's points are independent
    with density ``lambda / integral(lambda)``, and which points are kept depends on the counts
    only, so this is exactly the IPP conditioned on ``N = n_trees`` (Table 1 needs T trees; an
    unconditioned draw has a Poisson number of them, 6.6 on average for the paper's intensity).
    ``rng`` is a Generator, an int seed or None, as for :func:`sample_ipp`.
    """
    integer(n_trees, "n_trees", 1)
    rounds = integer(max_rounds, "max_rounds", 1)
    check_memory(
        2.0 * 16.0 * n_trees,  # (the rounds' points, and their concatenation)
        f"draw_tree_positions of n_trees = {n_trees}",
        "ask for fewer trees",
    )
    gen = generator(rng)
    lam = paper_intensity() if intensity is None else intensity
    # The bound of every round's thinning, found once (the estimate draws nothing, so each
    # round's points are those sample_ipp would draw estimating it itself).
    lam_max = estimate_lambda_max(lam, window) if callable(lam) else None
    if lam_max == 0.0:
        raise ValueError("the intensity is zero everywhere on the window: no tree can be drawn")
    got: list[np.ndarray] = []
    have = 0
    for done in range(1, rounds + 1):
        pts = sample_ipp(lam, window, gen, lambda_max=lam_max)
        got.append(pts)
        have += len(pts)
        if have >= n_trees:
            return np.concatenate(got)[:n_trees]
        # (a count out of reach is refused early: the points of `done` rounds are Poisson, so
        # their mean is below have + 5 sqrt(have) + 25 but for odds far below 1e-6; at that
        # rate, all the rounds would still give fewer than n_trees)
        if done == _EARLY_ROUNDS and (have + 5 * math.sqrt(have) + 25) * rounds < n_trees * done:
            break
    raise ValueError(
        f"n_trees = {n_trees} is out of reach: the intensity gives about {have / done:.3g} "
        f"points a realisation ({have} in {done}), and at most {rounds} realisations are "
        "drawn; ask for fewer trees, a larger intensity or window, or more max_rounds"
    )


#: Realisations after which :func:`draw_tree_positions` judges whether its count is in reach.
_EARLY_ROUNDS = 1000
