"""Matplotlib figures of scenes and echoes: :mod:`batecho.outputs.plots` under its public
name (``import batecho.plotting``)."""

from __future__ import annotations

from .outputs.plots import (
    BARK_COLOR,
    LEAF_COLOR,
    LOBE_COLORS,
    MEMBER_COLOR,
    PATH_COLOR,
    lobe_surface,
    plot_echo_image,
    plot_impulse,
    plot_impulses,
    plot_scene_3d,
    plot_spectrogram,
    plot_spectrum,
)

__all__ = [
    "BARK_COLOR",
    "LEAF_COLOR",
    "LOBE_COLORS",
    "MEMBER_COLOR",
    "PATH_COLOR",
    "lobe_surface",
    "plot_echo_image",
    "plot_impulse",
    "plot_impulses",
    "plot_scene_3d",
    "plot_spectrogram",
    "plot_spectrum",
]
