"""``python -m rodsim`` is the ``rodsim`` command."""

import sys

from rodsim.cli import main

sys.exit(main())
