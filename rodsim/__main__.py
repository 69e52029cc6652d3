"""``python -m rodsim`` is the ``rodsim`` command."""

from rodsim.app.cli import entry

entry()
