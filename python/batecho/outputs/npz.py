"""The NPZ files results are written as: the arrays, the settings that reproduce them as JSON
text, and the batecho version that made them."""

from __future__ import annotations

import json
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from .._core import __version__


def write_npz(
    path: str | os.PathLike,
    arrays: Mapping[str, Any],
    json_fields: Mapping[str, Any] | None = None,
) -> Path:
    """Write ``arrays`` (anything ``numpy.savez`` takes) to the NPZ file ``path``, each entry of
    ``json_fields`` as its JSON text (keys sorted), and ``batecho_version`` (this version,
    unless ``arrays`` gives one). Returns the path, which is ``path`` as given (no ``.npz``
    is added to it); ``numpy.load`` reads it back."""
    out: dict[str, Any] = dict(arrays)
    for key, value in (json_fields or {}).items():
        out[key] = json.dumps(value, sort_keys=True)
    out.setdefault("batecho_version", __version__)
    p = Path(path)
    # (through an open file: given a name, numpy.savez writes to it with ".npz" appended)
    with open(p, "wb") as f:
        np.savez(f, **out)
    return p


__all__ = ["write_npz"]
