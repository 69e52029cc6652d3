"""rodsim's version (also in pyproject.toml; tests/test_packaging.py checks they agree).
Imported by every layer that stamps it on an archive, so it imports nothing."""

__version__ = "0.1.0"
