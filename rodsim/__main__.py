"""``python -m rodsim`` is the ``rodsim`` command."""

import sys

from rodsim.app.cli import main

sys.exit(main())
