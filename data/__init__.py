"""The paper's scenes (Tables 1–3) as TOML files, shipped as the package rodsim.data."""
