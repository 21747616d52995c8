"""Matplotlib figures of scenes and echoes: :mod:`batecho.outputs.plots` and the two ears'
figures of :mod:`batecho.outputs.binaural` under their public name (``import
batecho.plotting``)."""

from __future__ import annotations

from .outputs.binaural import (
    plot_binaural_echo_images,
    plot_binaural_impulses,
    plot_interaural_differences,
)
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
    "plot_binaural_echo_images",
    "plot_binaural_impulses",
    "plot_echo_image",
    "plot_impulse",
    "plot_impulses",
    "plot_interaural_differences",
    "plot_scene_3d",
    "plot_spectrogram",
    "plot_spectrum",
]
