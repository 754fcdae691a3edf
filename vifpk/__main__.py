"""``python -m vifpk`` is the ``vifpk`` command (vifpk.harness.cli.entry.main)."""

import sys

from vifpk.harness.cli.entry import main

sys.exit(main())
