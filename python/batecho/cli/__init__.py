"""The ``batecho`` command line (``batecho ...``, ``python -m batecho ...``)."""

from __future__ import annotations

from .app import build_parser, main

__all__ = ["build_parser", "main"]
