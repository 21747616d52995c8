"""Matplotlib figures of scenes and echoes. Every function returns the Figure; nothing is shown.

Matplotlib runs with the Agg backend unless another one was chosen already. Units on the axes:
metres for positions and ranges, milliseconds for time, kHz for frequency, the echo's pressure
relative to the emitted pulse's for impulse responses, dB for magnitudes (re the largest
value, or for echo images re a high percentile of the envelope).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from .._validate import flag, positive_scalar
from ..echoes.simulate import samples_within

__all__ = [
    "WOOD_COLOR",
    "echo_image_reference",
    "lobe_surface",
    "plot_echo_image",
    "plot_impulse",
    "plot_impulses",
    "plot_scene_3d",
    "plot_spectrogram",
    "plot_spectrum",
]

#: Colours of the scene plots.
LEAF_COLOR = "#3a7d2c"
MEMBER_COLOR = "#d62728"
BARK_COLOR = "#6b4a2f"
#: Branches (cylinder segments) in scene pictures, and the wood's echoes in echo images.
WOOD_COLOR = "#8b5a2b"
WOOD_ECHO_COLOR = "#00e5ff"
PATH_COLOR = "#1f4e9e"
IMPULSE_COLOR = "#9bb7d9"
ENVELOPE_COLOR = "#1b2a49"
LOBE_COLORS = ("#ff7f0e", "#9467bd", "#17becf", "#e377c2", "#bcbd22", "#8c564b")


def _plt():
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    return plt


def _db(x: np.ndarray, ref: float, power: bool = False) -> np.ndarray:
    """``20 log10(x / ref)`` (or ``10 log10`` for powers); -inf where x = 0, all -inf if ref = 0."""
    if not ref > 0:
        return np.full(np.shape(x), -np.inf)
    with np.errstate(divide="ignore"):
        return (10.0 if power else 20.0) * np.log10(np.asarray(x) / ref)


def _one_receiver(echoes: Any, what: str) -> None:
    """Refuse echoes with a receiver axis in a figure of one receiver's echoes, naming the
    way to one."""
    if echoes.n_receivers:
        raise ValueError(
            f"{what} draws one receiver's echoes; these have {echoes.n_receivers} receivers: "
            "pass echoes.for_receiver(j), or draw them side by side with "
            "batecho.outputs.binaural"
        )


def _pose(echoes: Any, index: Any) -> int:
    """``index`` as a pose index of ``echoes`` (negative counts from the end)."""
    if isinstance(index, bool) or not isinstance(index, (int, np.integer)):
        raise TypeError(f"index must be an int pose index, got {index!r}")
    p = len(echoes)
    if not -p <= index < p:
        raise ValueError(f"pose index {index} out of range: the echoes have {p} poses")
    return int(index) % p


# ------------------------------------------------------------------------------- echoes


#: The impulse response's axis label: the echo's pressure relative to the emitted pulse's, in
#: the model's units (docs/model.md §5: ``g G L / (k r^2)`` summed, per metre).
IMPULSE_LABEL = "echo, relative pressure"


def _scale_of(peak: float) -> tuple[float, str]:
    """The power of ten ``10^e``, ``e = floor(log10(peak))``, that brings ``peak`` to [1, 10),
    and the label text that names it (``" (x10^-4)"`` in mathtext); ``(1, "")`` for a zero
    peak or ``e = 0``. (An axis label, not matplotlib's offset text, which collides with a
    secondary axis on top.)"""
    if not (peak > 0 and math.isfinite(peak)):
        return 1.0, ""
    e = math.floor(math.log10(peak))
    if e == 0:
        return 1.0, ""
    return 10.0**e, rf" ($\times10^{{{e}}}$)"


def plot_impulse(
    echoes,
    index: int = 0,
    ax=None,
    envelope: bool = True,
    title: str | None = None,
    max_range_m: float | None = None,
    *,
    legend: bool = True,
    range_axis: bool = True,
):
    """Impulse response of pose ``index``: time axis in ms, range (m) on a secondary axis.

    The impulse response ``y(t)`` is drawn in a light colour and its envelope
    ``|analytic signal|`` as a dark line over its upper half, so that both show. Its axis is
    the echo's pressure relative to the emitted pulse's (docs/model.md §5, a linear scale),
    scaled by a power of ten named in the label. ``max_range_m`` cuts the time axis at that
    range. A pose whose lobe holds no leaf has an impulse response that is exactly zero; the
    title says so.
    ``legend`` (outside the axes, on the right) and ``range_axis`` (on top) can be left out,
    e.g. on the inner panels of a grid.
    """
    _one_receiver(echoes, "plot_impulse")
    envelope, legend = flag(envelope, "envelope"), flag(legend, "legend")
    range_axis = flag(range_axis, "range_axis")
    index = _pose(echoes, index)
    plt = _plt()
    fig = None
    if ax is None:
        fig, ax = plt.subplots(figsize=(8, 3.2), constrained_layout=True)
    t_ms = echoes.times * 1e3
    y = echoes.impulse[index]
    v = echoes.sonar.sound_speed
    keep = samples_within(echoes, max_range_m)
    scale, unit = _scale_of(float(np.max(np.abs(y[keep]), initial=0.0)))
    ax.plot(t_ms[keep], y[keep] / scale, lw=0.5, color=IMPULSE_COLOR, label="impulse response")
    if envelope:
        from scipy.signal import hilbert

        env = np.abs(hilbert(y))[keep] / scale
        ax.plot(t_ms[keep], env, lw=0.5, color=ENVELOPE_COLOR, alpha=0.85, label="envelope")
    if not np.any(y[keep]):
        ax.set_yticks([0.0])
        ax.text(0.5, 0.62, "no echo", transform=ax.transAxes, ha="center", color="0.4")
    ax.set_xlabel("time (ms)")
    ax.set_ylabel(IMPULSE_LABEL + unit)
    if range_axis:
        sec = ax.secondary_xaxis(
            "top", functions=(lambda t: v * t * 1e-3 / 2, lambda r: 2 * r / v * 1e3)
        )
        sec.set_xlabel("range (m)")
    n = int(echoes.n_leaves[index])
    if title is None:
        title = (
            f"pose {index}: no leaf in the main lobe, the echo is exactly zero"
            if n == 0 and not np.any(y)
            else f"pose {index}: {n} leaves in the main lobe"
        )
    ax.set_title(title, fontsize=10)
    if legend:
        ax.legend(
            *_impulse_handles(ax),
            loc="upper left",
            bbox_to_anchor=(1.01, 1.0),
            borderaxespad=0.0,
            fontsize=8,
        )
    return fig or ax.figure


def _impulse_handles(ax) -> tuple[list, list[str]]:
    """Legend entries for ``ax``'s impulse response and envelope, with lines thick enough to
    see their colours."""
    from matplotlib.lines import Line2D

    labels = [ln.get_label() for ln in ax.lines]
    handles = [
        Line2D([], [], color=IMPULSE_COLOR, lw=2.0),
        Line2D([], [], color=ENVELOPE_COLOR, lw=1.5),
    ]
    names = ["impulse response", "envelope"]
    keep = [k for k in range(2) if names[k] in labels]
    return [handles[k] for k in keep], [names[k] for k in keep]


def plot_spectrum(echoes, index: int = 0, ax=None):
    """Magnitude (dB) of the band spectrum of pose ``index``, frequency in kHz."""
    _one_receiver(echoes, "plot_spectrum")
    index = _pose(echoes, index)
    plt = _plt()
    fig = None
    if ax is None:
        fig, ax = plt.subplots(figsize=(6, 3), constrained_layout=True)
    mag = np.abs(echoes.spectrum[index])
    db = _db(mag, float(mag.max()))
    # (a marker where there is one bin: a line of one point draws nothing)
    ax.plot(echoes.freqs / 1e3, db, lw=0.8, marker="o" if db.size == 1 else None)
    ax.set_xlabel("frequency (kHz)")
    ax.set_ylabel("|Y| (dB re max)")
    finite = db[np.isfinite(db)]
    ax.set_ylim(max(-80.0, float(finite.min())) if finite.size else -80.0, 3)
    if not finite.size:
        ax.set_title(f"pose {index}: no echo (spectrum exactly zero)", fontsize=10)
    return fig or ax.figure


def plot_impulses(
    echoes,
    indices: Sequence[int] | np.ndarray,
    ncols: int = 2,
    titles: Sequence[str] | None = None,
    max_range_m: float | None = None,
    sharey: bool = False,
):
    """A grid of impulse responses, one panel per pose in ``indices`` (``titles`` per panel).

    The panels share the time axis: its label and ticks are on the bottom row only and the
    range axis on the top row only; one legend below the grid.
    """
    sharey = flag(sharey, "sharey")
    plt = _plt()
    indices = [_pose(echoes, i) for i in indices]
    if not indices:
        raise ValueError("plot_impulses needs at least one pose index")
    if titles is not None and len(titles) != len(indices):
        raise ValueError(f"titles must name each of the {len(indices)} panels, got {len(titles)}")
    ncols = max(1, min(int(ncols), len(indices)))
    nrows = math.ceil(len(indices) / ncols)
    fig, axes = plt.subplots(
        nrows,
        ncols,
        figsize=(5 * ncols, 2.6 * nrows + 0.5),
        squeeze=False,
        constrained_layout=True,
        sharex=True,
        sharey=sharey,
    )
    flat = axes.ravel()
    for k, (ax, i) in enumerate(zip(flat, indices, strict=False)):
        row = k // ncols
        plot_impulse(
            echoes,
            i,
            ax=ax,
            title=None if titles is None else titles[k],
            max_range_m=max_range_m,
            legend=False,
            range_axis=row == 0,
        )
        # the bottom panel of each column carries the time axis
        if k + ncols < len(indices):
            ax.set_xlabel("")
            ax.tick_params(labelbottom=False)
        else:
            ax.tick_params(labelbottom=True)
    for ax in flat[len(indices) :]:
        ax.set_visible(False)
    fig.legend(
        *_impulse_handles(flat[0]), loc="outside lower center", ncols=2, fontsize=8, frameon=False
    )
    return fig


def _edges(x: np.ndarray) -> np.ndarray:
    """Cell edges around sorted centres ``x`` (midpoints, half a step beyond the ends)."""
    if len(x) == 1:
        return np.array([x[0] - 0.5, x[0] + 0.5])
    mid = 0.5 * (x[1:] + x[:-1])
    return np.concatenate([[x[0] - (mid[0] - x[0])], mid, [x[-1] + (x[-1] - mid[-1])]])


#: The percentile of the envelope that the echo image's colours are relative to: a few near
#: leaves cannot darken the rest of the image.
ECHO_IMAGE_PERCENTILE = 99.9


def echo_image_reference(
    envelope: np.ndarray, percentile: float = ECHO_IMAGE_PERCENTILE, floor_db: float = 120.0
) -> float:
    """The echo image's 0 dB: the ``percentile`` of the samples of ``envelope`` within
    ``floor_db`` of its largest (the band-limited pulses ring at a level far below that, over
    the whole record, and would otherwise count as samples when echoes are few); 0 if the
    envelope is zero."""
    peak = float(envelope.max(initial=0.0))
    if not peak > 0:
        return 0.0
    live = envelope[envelope >= peak * 10.0 ** (-floor_db / 20.0)]
    return float(np.percentile(live, percentile))


def plot_echo_image(
    echoes,
    ax=None,
    max_range_m: float | None = None,
    dynamic_range_db: float = 60.0,
    x: Any = None,
    xlabel: str | None = None,
    title: str | None = None,
    percentile: float = ECHO_IMAGE_PERCENTILE,
    wood: bool = True,
):
    """Echo "image" along a flight: the envelope in dB, pulses (x) by range (y).

    0 dB is the ``percentile`` (default 99.9) of the envelope's samples in the range shown
    (those within twice ``dynamic_range_db`` of the largest: :func:`echo_image_reference`), so
    that one loud echo (a leaf next to the sonar) does not darken the rest; louder
    samples show in the top colour (the colour bar's arrow), and the image spans
    ``dynamic_range_db`` below. ``x`` gives the pulses' coordinates (e.g. pulse times in s, the
    angle on a circle in deg or the distance to a target in m; distinct) with ``xlabel``; by
    default the pulse index. Pulses with no leaf in the lobe show as empty (exactly zero)
    columns. With ``wood`` and echoes of a scene with
    branches, the wood's own echo is outlined on top (:func:`overlay_wood_echoes`).
    """
    _one_receiver(echoes, "plot_echo_image")
    wood = flag(wood, "wood")
    dynamic_range_db = positive_scalar(dynamic_range_db, "dynamic_range_db", strict=True)
    plt = _plt()
    fig = None
    if ax is None:
        fig, ax = plt.subplots(figsize=(8, 4), constrained_layout=True)
    if not 0.0 < float(percentile) <= 100.0:
        raise ValueError(f"percentile must be in (0, 100], got {percentile!r}")
    rng = echoes.ranges
    keep = samples_within(echoes, max_range_m)
    env = echoes.envelope()[:, keep]
    db = _db(env, echo_image_reference(env, float(percentile), 2.0 * dynamic_range_db))
    p = len(echoes)
    xs = np.arange(p, dtype=np.float64) if x is None else np.asarray(x, dtype=np.float64)
    if xs.shape != (p,):
        raise ValueError(f"x must have one value per pulse ({p}), got shape {xs.shape}")
    if not np.all(np.isfinite(xs)):
        raise ValueError(f"x must be finite (pulse {int(np.argmin(np.isfinite(xs)))})")
    order = np.argsort(xs, kind="stable")
    if p > 1 and not np.all(np.diff(xs[order]) > 0):
        raise ValueError("x must have distinct values")
    r_edges = _edges(rng[keep])
    r_edges[0] = max(r_edges[0], 0.0)
    img = np.where(np.isfinite(db), db, -np.inf)[order].T
    im = ax.pcolormesh(
        _edges(xs[order]),
        r_edges,
        np.ma.masked_invalid(np.maximum(img, -dynamic_range_db - 1.0)),
        vmin=-dynamic_range_db,
        vmax=0,
        cmap="magma",
        shading="flat",
        rasterized=True,
    )
    ax.set_facecolor("black")
    ax.set_xlabel(xlabel or ("pulse" if x is None else "x"))
    ax.set_ylabel("range (m)")
    ax.set_ylim(0, rng[keep][-1])
    if wood and getattr(echoes, "wood_spectrum", None) is not None:
        overlay_wood_echoes(ax, echoes, xs, keep)
    if title:
        ax.set_title(title, fontsize=10)
    (fig or ax.figure).colorbar(
        im, ax=ax, extend="max", label=f"envelope (dB re its {percentile:g}th percentile)"
    )
    return fig or ax.figure


def overlay_wood_echoes(
    ax, echoes, x: np.ndarray, keep: np.ndarray, level_db: float = -12.0
) -> None:
    """Mark the wood's share of the echoes (trunks and branches) on an echo image: a tick across
    each pulse's column at every peak of the wood's envelope within ``level_db`` of that pulse's
    strongest wood echo (pulses at ``x``, one per pulse; ranges where ``keep``), fainter for
    pulses whose wood is weaker than the flight's strongest."""
    from scipy.signal import hilbert

    env = np.abs(hilbert(echoes.wood_impulse(), axis=-1))[:, keep]
    top = float(env.max())
    if not top > 0:
        return
    rng = echoes.ranges[keep]
    order = np.argsort(x, kind="stable")
    edges = _edges(np.asarray(x, dtype=np.float64)[order])
    for col, i in enumerate(order):
        peak_i = float(env[i].max())
        if not peak_i > 0:
            continue
        d = _db(env[i], peak_i)
        inner = d[1:-1]
        peak = np.flatnonzero((inner >= d[:-2]) & (inner > d[2:]) & (inner >= level_db)) + 1
        w = 0.08 * (edges[col + 1] - edges[col])
        ax.hlines(
            rng[peak],
            edges[col] + w,
            edges[col + 1] - w,
            colors=WOOD_ECHO_COLOR,
            linewidths=1.1,
            alpha=float(np.clip(1.0 + _db(np.asarray(peak_i), top) / 60.0, 0.3, 1.0)),
        )
    ax.plot([], [], color=WOOD_ECHO_COLOR, lw=1.1, label="wood echoes")
    ax.legend(loc="upper right", fontsize=7)


def plot_spectrogram(
    echoes, index: int = 0, ax=None, nperseg: int = 256, margin_hz: float | None = None
):
    """Spectrogram of the impulse response of pose ``index`` (``scipy.signal.spectrogram``,
    Hann segments of ``nperseg`` samples, 3/4 overlap), in dB re its largest value, 60 dB
    shown; a pose whose impulse response is exactly zero says so in the title.

    The frequency axis spans the band and ``margin_hz`` on either side (default a quarter of
    the band's width; finite and >= 0): the record holds nothing outside the band. The
    segments are not detrended (SciPy's default removes each segment's mean before the
    window, which leaves a false line at 0 Hz).
    """
    from scipy.signal import spectrogram

    _one_receiver(echoes, "plot_spectrogram")
    index = _pose(echoes, index)
    n = int(echoes.sonar.n_samples)
    if isinstance(nperseg, bool) or not isinstance(nperseg, (int, np.integer)):
        raise TypeError(f"nperseg must be an int, got {nperseg!r}")
    if not 2 <= nperseg <= n:
        raise ValueError(f"nperseg must be in [2, {n}] (the record's samples), got {nperseg}")
    if margin_hz is not None:
        margin_hz = positive_scalar(margin_hz, "margin_hz", allow_zero=True, strict=True)
    plt = _plt()
    fig = None
    if ax is None:
        fig, ax = plt.subplots(figsize=(7, 3.5), constrained_layout=True)
    f_lo, f_hi = echoes.sonar.band_hz
    pad = 0.25 * (f_hi - f_lo) if margin_hz is None else float(margin_hz)
    # (over its peak: the dB re max are the same, and the power neither overflows nor
    # underflows whatever the echoes' scale)
    y = echoes.impulse[index]
    peak = float(np.max(np.abs(y)))
    f, t, S = spectrogram(
        y / peak if peak > 0 else y,
        fs=echoes.sonar.fs,
        nperseg=nperseg,
        noverlap=nperseg * 3 // 4,
        detrend=False,
    )
    db = _db(S, float(S.max()), power=True)
    db = np.where(np.isfinite(db), db, -120.0)
    im = ax.pcolormesh(t * 1e3, f / 1e3, db, vmin=-60, vmax=0, shading="auto", cmap="magma")
    ax.set_ylim(max(0.0, f_lo - pad) / 1e3, min(echoes.sonar.fs / 2, f_hi + pad) / 1e3)
    ax.set_xlabel("time (ms)")
    ax.set_ylabel("frequency (kHz)")
    if not peak > 0:
        ax.set_title(f"pose {index}: no echo (the impulse response is exactly zero)", fontsize=10)
    (fig or ax.figure).colorbar(im, ax=ax, label="power (dB re max)")
    return fig or ax.figure


# -------------------------------------------------------------------------------- scenes


def _orthonormal_pair(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors orthogonal to the unit vector ``a`` and to each other."""
    h = np.array([0.0, 0.0, 1.0]) if abs(a[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    b1 = np.cross(h, a)
    b1 /= np.linalg.norm(b1)
    return b1, np.cross(a, b1)


def lobe_surface(sonar, pose, n_alpha: int = 36, n_phi: int = 48):
    """The boundary of the region where a leaf counts for one pose, as a closed surface.

    Returns ``(X, Y, Z)``, each (n_alpha + 1, n_phi + 1), world coordinates (m), for
    ``Axes3D.plot_surface``. With ``lobe="detectable"`` the boundary is
    ``r(az, el) = sqrt(r0^2 p0 G(az, el) / (10^(T/20) p_ref))`` (docs/model.md §3, two-way gain
    ``G``), capped at ``sonar.range_limit_m``; rows run over the angle from the beam centre out
    to 3.5 sigma (where ``r`` is a few mm) and the last row is the pulse position. With
    ``lobe="cone"`` it is the cone of ``cone_half_angle_deg`` around the beam axis, capped by
    the sphere of radius ``range_limit_m``.
    """
    if len(pose) != 1:
        raise ValueError(f"lobe_surface takes one pose; got {len(pose)} (index it: poses[i])")
    p = pose.positions[0]
    d, l_, u = pose.forward[0], pose.left[0], pose.up[0]
    rmax = float(sonar.range_limit_m)
    phi = np.linspace(0.0, 2.0 * np.pi, n_phi + 1)
    if sonar.lobe == "cone":
        axis = d
        alpha = np.linspace(0.0, math.radians(sonar.cone_half_angle_deg), n_alpha)
    else:
        az0, el0 = (math.radians(v) for v in sonar.beam.center_deg)
        axis = (
            math.cos(el0) * math.cos(az0) * d
            + math.cos(el0) * math.sin(az0) * l_
            + math.sin(el0) * u
        )
        sig = max(sonar.beam.sigmas_rad)
        if sonar.receiver is not None:
            sig = max(sig, *sonar.receiver.sigmas_rad)
        alpha = np.linspace(0.0, min(3.5 * sig, math.radians(175.0)), n_alpha)
    b1, b2 = _orthonormal_pair(axis / np.linalg.norm(axis))
    A, P = np.meshgrid(alpha, phi, indexing="ij")
    e = (
        np.cos(A)[..., None] * axis
        + (np.sin(A) * np.cos(P))[..., None] * b1
        + (np.sin(A) * np.sin(P))[..., None] * b2
    )
    if sonar.lobe == "cone":
        r = np.full(A.shape, rmax)
    else:
        ed, el_, eu = e @ d, e @ l_, e @ u
        az = np.arctan2(el_, ed)
        el = np.arctan2(eu, np.hypot(ed, el_))
        s_tx = sonar.beam.gain(az, el)
        s_rx = s_tx if sonar.receiver is None else sonar.receiver.gain(az, el)
        reach2 = (
            sonar.r0_m**2
            * sonar.p0_pa
            * s_tx
            * s_rx
            / (10.0 ** (sonar.threshold_db / 20.0) * sonar.p_ref_pa)
        )
        r = np.minimum(np.sqrt(reach2), rmax)
    pts = p + r[..., None] * e
    pts = np.concatenate([pts, np.broadcast_to(p, (1, *pts.shape[1:]))], axis=0)
    return pts[..., 0], pts[..., 1], pts[..., 2]


def _scene_branches(obj: Any, branches: Any, bark_drawn: bool):
    """The branches to draw (see :func:`plot_scene_3d`), or None."""
    from ..trees.branches import Branches

    if branches is False:
        return None
    if isinstance(branches, Branches):
        return branches
    if branches is not None and branches is not True:
        raise TypeError(
            f"branches must be None, True, False or a batecho.Branches, got {branches!r}"
        )
    if branches is None and bark_drawn:
        return None
    own = getattr(obj, "branches", None)
    return own if isinstance(own, Branches) else None


def draw_branches(ax, branches, max_segments: int = 6000) -> list[np.ndarray]:
    """Draw branch segments on 3-D axes as lines whose width follows their radius (the
    thickest ``max_segments``); returns their bounds ``[lo, hi]``."""
    from mpl_toolkits.mplot3d.art3d import Line3DCollection

    s, e, r = branches.starts, branches.ends, branches.radii
    k = np.arange(len(r))
    if len(k) > max_segments:
        k = np.sort(np.argsort(-r, kind="stable")[: int(max_segments)])
    lw = np.clip(40.0 * r[k], 0.4, 6.0)
    ax.add_collection3d(
        Line3DCollection(
            np.stack([s[k], e[k]], axis=1),
            colors=WOOD_COLOR,
            linewidths=lw,
            alpha=0.9,
            label=f"branches ({len(r)})",
        )
    )
    both = np.concatenate([s, e])
    return [both.min(axis=0), both.max(axis=0)]


def _scene_leaves(obj: Any):
    from ..forest.scene import Scene
    from ..trees.branches import Branches
    from ..trees.leaves import Leaves

    if isinstance(obj, Leaves):
        return obj
    if isinstance(obj, Scene):
        return obj.leaves  # (None in a scene of branches alone)
    lv = getattr(obj, "leaves", None)
    if isinstance(lv, Leaves):
        return lv
    if isinstance(getattr(obj, "branches", None), Branches):
        return None
    if callable(getattr(obj, "scene", None)):
        return obj.scene().leaves
    raise TypeError(
        f"plot_scene_3d needs Leaves, a Scene, or an object with .leaves; got {type(obj).__name__}"
    )


def _bark_arrays(obj: Any, bark: Any) -> tuple[np.ndarray, np.ndarray] | None:
    if bark is False:
        return None
    src = obj if bark is None or bark is True else bark
    if isinstance(src, tuple) and len(src) in (2, 3):
        v, f = src[0], src[1]
    elif callable(getattr(src, "bark", None)):  # a Forest: bark() -> (vertices, faces, owner)
        v, f = src.bark()[:2]
    else:
        v = getattr(src, "bark_vertices", None)
        f = getattr(src, "bark_faces", None)
    if v is None or f is None:
        return None
    v = np.asarray(v, dtype=np.float64)
    f = np.asarray(f, dtype=np.int64)
    if v.ndim != 2 or v.shape[-1] != 3 or f.ndim != 2 or f.shape[-1] != 3 or not len(f):
        return None
    return v, f


def _trajectory_points(trajectory: Any) -> np.ndarray | None:
    if trajectory is None:
        return None
    pos = getattr(trajectory, "positions", None)  # Flight, Poses
    if pos is not None and not callable(pos):
        return np.asarray(pos, dtype=np.float64)
    if callable(getattr(trajectory, "position", None)):  # timed Trajectory
        dur = float(getattr(trajectory, "duration", math.inf))
        if not math.isfinite(dur):
            raise ValueError("a trajectory without a finite duration cannot be drawn")
        return np.asarray(trajectory.position(np.linspace(0.0, dur, 400)), dtype=np.float64)
    arr = np.asarray(trajectory, dtype=np.float64)
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise ValueError(f"trajectory must be (k, 3) points, got shape {arr.shape}")
    return arr


def _drawn(what: str, n: int, shown: int) -> str:
    """A legend label that says when only some of ``n`` points are drawn."""
    return f"{what} ({n:,})" if shown == n else f"{what} ({n:,}; {shown:,} drawn)"


def _subsample(idx: np.ndarray, k: int, seed: int = 0) -> np.ndarray:
    if len(idx) <= k:
        return idx
    return np.sort(np.random.default_rng(seed).choice(idx, size=k, replace=False))


def plot_scene_3d(
    leaves_or_scene: Any,
    poses=None,
    sonar=None,
    members: Any = None,
    trajectory: Any = None,
    bark: Any = None,
    ax=None,
    max_points: int = 6000,
    lobe_poses: Sequence[int] | None = None,
    max_bark_faces: int = 4000,
    title: str | None = None,
    elev: float = 22.0,
    azim: float = -60.0,
    branches: Any = None,
    max_branches: int = 6000,
    lobe_labels: Sequence[str] | None = None,
):
    """The 3-D scene: leaves, bark or branches, the flight path, the pulses, the sonar lobes.

    ``leaves_or_scene``: Leaves, a Scene, or anything with ``.leaves`` (a tree, a forest, an OBJ
    Mesh). At most ``max_points`` leaf centres are drawn (a fixed random subset; the legend
    then says how many of how many).
    ``poses``: pulse poses, drawn as markers with a short arrow along the beam axis.
    ``sonar`` and ``lobe_poses`` (indices into ``poses``; default: every pose if there are at
    most 4, else none): the lobe of each is drawn as a translucent surface
    (:func:`lobe_surface`). ``members``: leaf indices to highlight (e.g. from
    :func:`batecho.lobe_members`), or a list of such arrays. ``trajectory``: a (k, 3) polyline,
    a timed trajectory or a Flight, drawn as a line. ``bark``: None (the object's own bark:
    ``bark_vertices``/``bark_faces``, or a forest's ``bark()``), False, ``(vertices, faces)``
    or an object with those; at most ``max_bark_faces`` triangles, the largest (the legend
    says so). ``branches``: the woody skeleton as segments (:func:`draw_branches`): None (the
    object's own, a Scene's, Tree's or Forest's, where no bark mesh is drawn), False, True (the
    object's own, always) or a :class:`~batecho.Branches`; at most ``max_branches``, the
    thickest. The legend, below the axes, keys each lobe to its pulse (or to ``lobe_labels``,
    one per lobe drawn). Axes have equal scale, with ticks in proportion to their length.
    """
    plt = _plt()
    from matplotlib.patches import Patch
    from matplotlib.ticker import MaxNLocator
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    leaves = _scene_leaves(leaves_or_scene)
    fig = None
    if ax is None:
        fig = plt.figure(figsize=(8, 7), constrained_layout=True)
        ax = fig.add_subplot(projection="3d")
    # (a scene of branches alone has no leaves)
    c = np.zeros((0, 3)) if leaves is None else leaves.centers
    bounds = [c.min(axis=0), c.max(axis=0)] if len(c) else []
    if len(c):
        shown = _subsample(np.arange(len(c)), int(max_points))
        ax.scatter(
            c[shown, 0],
            c[shown, 1],
            c[shown, 2],
            s=1.0,
            c=LEAF_COLOR,
            alpha=0.35,
            linewidths=0,
            depthshade=False,
            label=_drawn("leaves", len(c), len(shown)),
        )
    extra: list = []  # legend entries of what scatter and plot do not label themselves
    bk = _bark_arrays(leaves_or_scene, bark)
    if bk is not None:
        v, f = bk
        tri = v[f]
        n_tri = len(tri)
        if n_tri > max_bark_faces:  # the largest triangles: trunk and main branches first
            area = np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
            tri = tri[np.sort(np.argsort(-area, kind="stable")[: int(max_bark_faces)])]
        ax.add_collection3d(
            Poly3DCollection(tri, facecolor=BARK_COLOR, edgecolor="none", alpha=0.6)
        )
        label = (
            "bark" if len(tri) == n_tri else f"bark (largest {len(tri):,} of {n_tri:,} triangles)"
        )
        extra.append(Patch(facecolor=BARK_COLOR, alpha=0.6, label=label))
        bounds += [v.min(axis=0), v.max(axis=0)]
    wood = _scene_branches(leaves_or_scene, branches, bark_drawn=bk is not None)
    if wood is not None:
        bounds += draw_branches(ax, wood, max_branches)
    if members is not None and len(c):
        parts = members if isinstance(members, (list, tuple)) else [members]
        arrs = [np.asarray(m, dtype=np.int64).ravel() for m in parts]
        idx = np.unique(np.concatenate(arrs)) if arrs else np.zeros(0, np.int64)
        if idx.size:
            n_members = idx.size
            idx = _subsample(idx, int(max_points), seed=2)
            ax.scatter(
                c[idx, 0],
                c[idx, 1],
                c[idx, 2],
                s=4.0,
                c=MEMBER_COLOR,
                alpha=0.9,
                linewidths=0,
                depthshade=False,
                label=_drawn("leaves in a lobe", n_members, idx.size),
            )
    path = _trajectory_points(trajectory)
    if path is not None and len(path):
        ax.plot(path[:, 0], path[:, 1], path[:, 2], color=PATH_COLOR, lw=1.2, label="flight path")
        bounds += [path.min(axis=0), path.max(axis=0)]
    if poses is not None:
        pp = poses.positions
        many = len(poses) > 30
        ax.scatter(
            pp[:, 0],
            pp[:, 1],
            pp[:, 2],
            s=6 if many else 22,
            c="k",
            marker="o",
            depthshade=False,
            label=f"pulses ({len(poses)})",
        )
        sel = (
            (range(len(poses)) if len(poses) <= 4 else [])
            if lobe_poses is None
            else [int(i) for i in lobe_poses]
        )
        # Beam axes: every pulse's when there are few, else those of the lobes drawn.
        ai = np.asarray(list(sel) if many else range(len(poses)), dtype=np.int64)
        span = float(np.max(np.ptp(np.vstack(bounds), axis=0)))
        arrow = 0.08 * max(span, 1.0)
        if ai.size:
            fw = poses.forward[ai] * arrow
            ax.quiver(
                pp[ai, 0], pp[ai, 1], pp[ai, 2], fw[:, 0], fw[:, 1], fw[:, 2], color="k", lw=0.8
            )
        bounds += [pp.min(axis=0), pp.max(axis=0)]
        if lobe_labels is not None and len(lobe_labels) != len(sel):
            raise ValueError(f"lobe_labels must name each of the {len(sel)} lobes drawn")
        if sonar is not None:
            for k, i in enumerate(sel):
                X, Y, Z = lobe_surface(sonar, poses[i])
                extra.append(
                    Patch(
                        facecolor=LOBE_COLORS[k % len(LOBE_COLORS)],
                        alpha=0.45,
                        label=f"lobe of pulse {i}" if lobe_labels is None else lobe_labels[k],
                    )
                )
                ax.plot_surface(
                    X,
                    Y,
                    Z,
                    color=LOBE_COLORS[k % len(LOBE_COLORS)],
                    alpha=0.18,
                    linewidth=0,
                    shade=False,
                )
                ax.plot_wireframe(
                    X,
                    Y,
                    Z,
                    rstride=6,
                    cstride=6,
                    color=LOBE_COLORS[k % len(LOBE_COLORS)],
                    lw=0.3,
                    alpha=0.5,
                )
                # The lobe is part of the picture: keep the axes wide enough to hold it.
                bounds += [
                    np.array([X.min(), Y.min(), Z.min()]),
                    np.array([X.max(), Y.max(), Z.max()]),
                ]
    lo = np.min(np.vstack(bounds), axis=0)
    hi = np.max(np.vstack(bounds), axis=0)
    pad = 0.03 * max(float((hi - lo).max()), 1e-3)
    lo, hi = lo - pad, hi + pad
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_zlim(lo[2], hi[2])
    ax.set_box_aspect(tuple(np.maximum(hi - lo, 1e-3)))
    # ticks in proportion to each axis's drawn length, so that a short axis's labels do not
    # overlap
    spans = np.maximum(hi - lo, 1e-3)
    for axis, span in zip((ax.xaxis, ax.yaxis, ax.zaxis), spans, strict=True):
        nbins = max(2, round(7 * float(span / spans.max())))
        axis.set_major_locator(MaxNLocator(nbins=nbins, steps=[1, 2, 5, 10]))
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_zlabel("z (m)")
    ax.view_init(elev=elev, azim=azim)
    handles, _ = ax.get_legend_handles_labels()
    leg = ax.legend(
        handles=handles + extra,
        loc="upper center",
        bbox_to_anchor=(0.5, 0.0),
        ncols=3,
        fontsize=7,
        frameon=False,
    )
    for h in getattr(leg, "legend_handles", getattr(leg, "legendHandles", [])):
        if hasattr(h, "set_sizes"):
            h.set_sizes([12.0])
    if title:
        ax.set_title(title, fontsize=10)
    return fig or ax.figure
