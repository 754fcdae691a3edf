"""``python -m harness`` is the ``vifpk`` command."""

import sys

from .cli import main

sys.exit(main())
