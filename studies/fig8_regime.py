"""Fig. 8 in the paper's damping regime: the mass matrix scaled so that h² ω₁² ≈ 0.003
(docs/design.md, erratum 12; ``solver.paper.h2_omega2``), where ξ = 0.9 damps the slowest mode
critically. Table 1 in SI units gives h² ω₁² ≈ 26 and ξ has no effect (study ``fig8``)."""

from rodsim.app.study import Study, Sweep

XI = ("xi", "solver.paper.xi")

STUDY = Study(
    name="fig8_regime",
    title="tip error per time step of the paper's integrator for several damping constants ξ, "
          "masses scaled to h² ω₁² = 0.003 (Table 1, 50 g, Δt = 0.3 s)",
    paper="Fig. 8: error vs iteration for several ξ; ξ = 0.90 converges fastest without "
          "oscillation (at Δt = 0.3 s)",
    scene="table1-50g",
    integrator="paper",
    overrides=("solver.paper.h2_omega2=0.003",),
    reference="paper",
    plot="error_vs_iteration",
    history=True,
    sweeps={
        "small": [Sweep(*XI, (0.5, 0.9, 1.0), "1", "damping constant ξ")],
        "full": [Sweep(*XI, (0.5, 0.7, 0.8, 0.9, 0.95, 0.99, 1.0), "1", "damping constant ξ")],
    },
)
