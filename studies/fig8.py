"""Fig. 8: error against iteration for several damping constants ξ (paper integrator, 50 g)."""

from rodsim.app.study import Study, Sweep

XI = ("xi", "solver.paper.xi")
H = ("h", "solver.paper.h")

STUDY = Study(
    name="fig8",
    title="tip error per time step of the paper's integrator for several damping constants ξ "
          "(Table 1, 50 g)",
    paper="Fig. 8: error vs iteration for several ξ; ξ = 0.90 converges fastest without "
          "oscillation (at Δt = 0.3 s)",
    scene="table1-50g",
    integrator="paper",
    reference="paper",
    plot="error_vs_iteration",
    history=True,
    sweeps={
        "small": [Sweep(*XI, (0.5, 0.99), "1", "damping constant ξ"),
                  Sweep(*H, (0.3, 0.1), "s", "time step Δt")],
        "full": [Sweep(*XI, (0.5, 0.7, 0.8, 0.9, 0.95, 0.99), "1", "damping constant ξ"),
                 Sweep(*H, (0.3, 0.03), "s", "time step Δt")],
    },
)
