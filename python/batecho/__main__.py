"""``python -m batecho ...``: the same as the ``batecho`` command."""

import sys

from .cli import main

sys.exit(main())
