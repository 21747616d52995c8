"""Figures of two receivers' echoes: the two ears' impulse responses and echo images side by
side, and the interaural level and time differences along a flight. Every function returns
the Figure; nothing is shown."""

from __future__ import annotations

import warnings
from typing import Any

import numpy as np

from .._validate import positive_scalar
from ..echoes.binaural import interaural_level_difference, interaural_time_difference
from ..echoes.simulate import samples_within
from .plots import _db, _edges, _plt, _pose, plot_impulse

__all__ = ["plot_binaural_echo_images", "plot_binaural_impulses", "plot_interaural_differences"]


def _ear_names(echoes) -> list[str]:
    from ..echoes.export import _receiver_table

    return _receiver_table(echoes)[0]


def _check(echoes) -> None:
    if echoes.n_receivers < 2:
        raise ValueError(
            f"two-ear figures need echoes with two receivers or more, got {echoes.n_receivers} "
            "(Sonar.binaural)"
        )


def plot_binaural_impulses(echoes, index: int = 0, max_range_m: float | None = None):
    """The impulse responses of pose ``index`` at each receiver, side by side, on one
    amplitude scale."""
    _check(echoes)
    index = _pose(echoes, index)
    plt = _plt()
    r = echoes.n_receivers
    fig, axes = plt.subplots(1, r, figsize=(5 * r, 3.4), sharey=True, constrained_layout=True)
    names = _ear_names(echoes)
    for j, ax in enumerate(axes):
        e = echoes.for_receiver(j)
        n = int(e.n_leaves[index])
        plot_impulse(
            e,
            index,
            ax=ax,
            max_range_m=max_range_m,
            title=f"{names[j]} ear, pose {index}: {n} leaves",
        )
    return fig


def plot_binaural_echo_images(
    echoes,
    x: Any = None,
    xlabel: str | None = None,
    max_range_m: float | None = None,
    dynamic_range_db: float = 60.0,
):
    """The echo images (envelope in dB, pulses by range) of each receiver side by side, all in
    dB re the largest envelope of any receiver, so that the ears' levels compare."""
    _check(echoes)
    dynamic_range_db = positive_scalar(dynamic_range_db, "dynamic_range_db", strict=True)
    plt = _plt()
    r, p = echoes.n_receivers, len(echoes)
    xs = np.arange(p, dtype=np.float64) if x is None else np.asarray(x, dtype=np.float64)
    if xs.shape != (p,):
        raise ValueError(f"x must have one value per pulse ({p}), got shape {xs.shape}")
    if not np.all(np.isfinite(xs)):
        raise ValueError(f"x must be finite (pulse {int(np.argmin(np.isfinite(xs)))})")
    order = np.argsort(xs, kind="stable")
    if p > 1 and not np.all(np.diff(xs[order]) > 0):
        raise ValueError("x must have distinct values")
    env = echoes.envelope()
    db = _db(env, float(env.max()))
    rng = echoes.ranges
    keep = samples_within(echoes, max_range_m)
    r_edges = _edges(rng[keep])
    r_edges[0] = max(r_edges[0], 0.0)
    fig, axes = plt.subplots(1, r, figsize=(5.5 * r, 4), sharey=True, constrained_layout=True)
    names = _ear_names(echoes)
    im = None
    for j, ax in enumerate(axes):
        img = np.where(np.isfinite(db[:, j]), db[:, j], -np.inf)[order][:, keep].T
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
        ax.set_title(f"{names[j]} ear", fontsize=10)
    axes[0].set_ylabel("range (m)")
    axes[0].set_ylim(0, rng[keep][-1])
    fig.colorbar(im, ax=list(axes), label="envelope (dB re the largest of all ears)")
    return fig


def _silent_ears(echoes, max_range_m: float | None) -> np.ndarray:
    """(p, R) True where a receiver's impulse response is zero over the window."""
    y = echoes.impulse[..., samples_within(echoes, max_range_m)]
    return ~np.any(y != 0.0, axis=-1)


def plot_interaural_differences(
    echoes, x: Any = None, xlabel: str | None = None, max_range_m: float | None = None
):
    """The interaural level difference (dB, left minus right) and time difference (µs,
    positive when the left ear hears first) of each pulse along the flight.

    Where an ear hears nothing the differences are undefined: those pulses are marked on the
    zero line by which ear is silent, a note in the figure counts them, and a
    :class:`UserWarning` names them."""
    _check(echoes)
    plt = _plt()
    p = len(echoes)
    xs = np.arange(p, dtype=np.float64) if x is None else np.asarray(x, dtype=np.float64)
    if xs.shape != (p,):
        raise ValueError(f"x must have one value per pulse ({p}), got shape {xs.shape}")
    ild = interaural_level_difference(echoes, max_range_m=max_range_m)
    itd = interaural_time_difference(echoes, max_range_m=max_range_m)
    silent = _silent_ears(echoes, max_range_m)[:, :2]
    names = _ear_names(echoes)[:2]
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(8, 5), sharex=True, constrained_layout=True)
    for ax, v, color in ((a1, ild, "tab:blue"), (a2, itd * 1e6, "tab:red")):
        ok = np.isfinite(v)
        # (the line joins neighbouring pulses that both have a value)
        ax.plot(xs, np.where(ok, v, np.nan), "-", lw=1, color=color)
        ax.plot(xs[ok], v[ok], "o", ms=3, color=color)
        ax.axhline(0.0, color="0.6", lw=0.8)
        for j, marker in ((0, "<"), (1, ">")):
            at = silent[:, j]
            if at.any():
                ax.plot(
                    xs[at],
                    np.zeros(int(at.sum())),
                    marker,
                    ms=6,
                    color="0.35",
                    ls="none",
                    label=f"{names[j]} ear hears nothing",
                )
    a1.set_ylabel("ILD (dB, left - right)")
    a2.set_ylabel("ITD (µs, right - left)")
    a2.set_xlabel(xlabel or ("pulse" if x is None else "x"))
    a1.set_title("Interaural differences along the flight", fontsize=10)
    undefined = np.flatnonzero(silent.any(axis=1))
    if undefined.size:
        a1.legend(loc="best", fontsize=8)
        note = (
            f"{undefined.size} of {p} pulses have an ear that hears nothing: "
            "no interaural difference there"
        )
        fig.text(0.5, 0.01, note, ha="center", va="bottom", fontsize=8, color="0.3")
        shown = ", ".join(str(int(i)) for i in undefined[:10])
        more = ", ..." if undefined.size > 10 else ""
        who = " and ".join(
            f"the {names[j]} ear at {int(silent[:, j].sum())}"
            for j in range(2)
            if silent[:, j].any()
        )
        warnings.warn(
            f"plot_interaural_differences: {note} (pulses {shown}{more}; silent: {who})",
            UserWarning,
            stacklevel=2,
        )
    return fig
