"""Fig. 7B: accuracy against the number of control points N (50 g)."""

from rodsim.app.study import Study, Sweep

STUDY = Study(
    name="fig7b",
    title="tip error against the number of control points N (Table 1, 50 g)",
    paper="Fig. 7B: the error against the analytical model falls below 1 % of L at N ≈ 40",
    scene="table1-50g",
    integrator="static",
    reference="paper",
    plot="error_vs_parameter",
    sweeps={
        "small": [Sweep("nodes", "rods.catheter.nodes", (5, 10, 20, 40), "1",
                        "number of control points N")],
        "full": [Sweep("nodes", "rods.catheter.nodes", (5, 10, 20, 40, 80, 160, 320), "1",
                       "number of control points N")],
    },
)
