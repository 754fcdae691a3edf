"""``python -m vifpk.harness`` is the ``vifpk`` command (``python -m vifpk`` too)."""

import sys

from .cli import main

sys.exit(main())
