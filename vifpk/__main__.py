"""``python -m vifpk`` is the ``vifpk`` command (vifpk.harness.cli.app.main)."""

import sys

from vifpk.harness.cli.app import main

sys.exit(main())
