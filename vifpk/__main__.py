"""``python -m vifpk`` is the ``vifpk`` command (vifpk.harness.cli.main)."""

import sys

from vifpk.harness.cli import main

sys.exit(main())
