"""A user's rod, drawn at random: what the physical-time and modes tests' seeded families
are made of (steel and nitinol wires, soft polymer catheters), as a user writes them from
docs/scenes.md."""

from __future__ import annotations

from typing import Any

import numpy as np

#: The kinds of rod, in the order a family's seeds cycle through them.
KINDS = ("steel", "nitinol", "polymer")


def user_rod(rng: np.random.Generator, kind: str,
             polymer_length: tuple[float, float] = (0.05, 0.3)) -> dict[str, Any]:
    """A rod table of ``kind`` (length, radius, moduli, density, Poisson ratio) drawn from
    ``rng``: a polymer catheter of length in ``polymer_length`` [m], radius 0.8–3 mm and
    E 5–60 MPa, or a steel (E 200 GPa) or nitinol (E 40–75 GPa) wire of 0.1–0.5 m and
    radius 0.2–1 mm."""
    if kind == "polymer":
        return {"length": rng.uniform(*polymer_length), "radius": rng.uniform(0.8e-3, 3e-3),
                "youngs_modulus": rng.uniform(5e6, 60e6), "density": rng.uniform(1000, 1250),
                "poisson_ratio": 0.45}
    return {"length": rng.uniform(0.1, 0.5), "radius": rng.uniform(0.2e-3, 1e-3),
            "youngs_modulus": 200e9 if kind == "steel" else rng.uniform(40e9, 75e9),
            "density": 7900.0 if kind == "steel" else 6450.0, "poisson_ratio": 0.3}
