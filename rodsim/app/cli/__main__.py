"""``python -m rodsim.app.cli`` is the ``rodsim`` command."""

from rodsim.app.cli import entry

entry()
