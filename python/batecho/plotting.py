"""Matplotlib figures of echoes. Every function returns the Figure; nothing is shown."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np


def _plt():
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    return plt


def plot_impulse(echoes, index: int = 0, ax=None, envelope: bool = True, title: str | None = None):
    """Impulse response of pose ``index``: time axis in ms, range (m) on a secondary axis."""
    plt = _plt()
    fig = None
    if ax is None:
        fig, ax = plt.subplots(figsize=(8, 3.2), constrained_layout=True)
    t_ms = echoes.times * 1e3
    y = echoes.impulse[index]
    ax.plot(t_ms, y, lw=0.6, color="tab:blue", label="impulse response")
    if envelope:
        ax.plot(t_ms, echoes.envelope()[index], lw=0.8, color="tab:orange", label="envelope")
    ax.set_xlabel("time (ms)")
    ax.set_ylabel("amplitude")
    v = echoes.sonar.sound_speed
    sec = ax.secondary_xaxis(
        "top", functions=(lambda t: v * t * 1e-3 / 2, lambda r: 2 * r / v * 1e3)
    )
    sec.set_xlabel("range (m)")
    n = int(echoes.n_leaves[index])
    ax.set_title(title or f"pose {index}: {n} leaves in the main lobe", fontsize=10)
    ax.legend(loc="upper right", fontsize=8)
    return fig or ax.figure


def plot_spectrum(echoes, index: int = 0, ax=None):
    """Magnitude (dB) of the band spectrum of pose ``index``, frequency in kHz."""
    plt = _plt()
    fig = None
    if ax is None:
        fig, ax = plt.subplots(figsize=(6, 3), constrained_layout=True)
    mag = np.abs(echoes.spectrum[index])
    with np.errstate(divide="ignore"):
        db = 20 * np.log10(mag / mag.max()) if mag.max() > 0 else np.full_like(mag, -np.inf)
    ax.plot(echoes.freqs / 1e3, db, lw=0.8)
    ax.set_xlabel("frequency (kHz)")
    ax.set_ylabel("|Y| (dB re max)")
    ax.set_ylim(max(-80, np.nanmin(db[np.isfinite(db)]) if np.isfinite(db).any() else -80), 3)
    return fig or ax.figure


def plot_impulses(echoes, indices: Sequence[int], ncols: int = 2):
    """A grid of impulse responses, one panel per pose in ``indices``."""
    plt = _plt()
    indices = list(indices)
    nrows = int(np.ceil(len(indices) / ncols))
    fig, axes = plt.subplots(
        nrows, ncols, figsize=(5 * ncols, 2.6 * nrows), squeeze=False, constrained_layout=True
    )
    for ax, i in zip(axes.ravel(), indices, strict=False):
        plot_impulse(echoes, i, ax=ax)
    for ax in axes.ravel()[len(indices) :]:
        ax.set_visible(False)
    return fig


def plot_echo_image(echoes, ax=None, max_range_m: float | None = None, dynamic_range_db=60.0):
    """Echo "image" along a flight: envelope in dB, pulses (x) by range (y)."""
    plt = _plt()
    fig = None
    if ax is None:
        fig, ax = plt.subplots(figsize=(8, 4), constrained_layout=True)
    env = echoes.envelope()
    peak = env.max()
    with np.errstate(divide="ignore"):
        db = 20 * np.log10(env / peak) if peak > 0 else np.full_like(env, -np.inf)
    rng = echoes.ranges
    rmax = max_range_m or rng[-1]
    keep = rng <= rmax
    im = ax.imshow(
        db[:, keep].T,
        origin="lower",
        aspect="auto",
        vmin=-dynamic_range_db,
        vmax=0,
        extent=(-0.5, len(echoes) - 0.5, 0, rng[keep][-1]),
        cmap="magma",
    )
    ax.set_xlabel("pulse")
    ax.set_ylabel("range (m)")
    (fig or ax.figure).colorbar(im, ax=ax, label="envelope (dB re max)")
    return fig or ax.figure


def plot_spectrogram(echoes, index: int = 0, ax=None, nperseg: int = 256):
    """Spectrogram of the impulse response of pose ``index`` (scipy.signal.spectrogram)."""
    from scipy.signal import spectrogram

    plt = _plt()
    fig = None
    if ax is None:
        fig, ax = plt.subplots(figsize=(7, 3.5), constrained_layout=True)
    f, t, S = spectrogram(
        echoes.impulse[index], fs=echoes.sonar.fs, nperseg=nperseg, noverlap=nperseg * 3 // 4
    )
    with np.errstate(divide="ignore"):
        db = 10 * np.log10(S / S.max()) if S.max() > 0 else np.full_like(S, -120.0)
    im = ax.pcolormesh(t * 1e3, f / 1e3, db, vmin=-60, vmax=0, shading="auto", cmap="magma")
    ax.set_xlabel("time (ms)")
    ax.set_ylabel("frequency (kHz)")
    (fig or ax.figure).colorbar(im, ax=ax, label="dB re max")
    return fig or ax.figure


__all__ = ["plot_echo_image", "plot_impulse", "plot_impulses", "plot_spectrogram", "plot_spectrum"]
