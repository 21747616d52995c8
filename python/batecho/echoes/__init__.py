"""Echoes: the Rust core's ``simulate`` and ``lobe_members``, their result, and the canonical
leaf-box scene the echo engine is benchmarked on."""

from __future__ import annotations

from .simulate import DEFAULT_METHOD, DEFAULT_TOL, METHODS, Echoes, lobe_members, simulate

__all__ = ["DEFAULT_METHOD", "DEFAULT_TOL", "METHODS", "Echoes", "lobe_members", "simulate"]
