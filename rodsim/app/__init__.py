"""What a user runs: the Python entry points (api), the command line (cli), studies and their
runner, plots, progress lines, and the inverse tools. The top layer (docs/architecture.md)."""
