"""``python -m batecho.dataset ...``: the same as ``batecho dataset ...``."""

from __future__ import annotations

import sys

from .cli import main

sys.exit(main())
