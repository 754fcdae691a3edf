"""``python -m vifpk.harness`` is the ``vifpk`` command (``python -m vifpk`` too)."""

import sys

from vifpk.harness.cli.entry import main

sys.exit(main())
