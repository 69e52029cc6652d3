"""Fig. 7A: accuracy against the centerline penalty constant K_P (50 g, N = 40)."""

from rodsim.app.study import Study, Sweep

K_P = ("K_P", "rods.catheter.centerline.K_P")

STUDY = Study(
    name="fig7a",
    title="tip error against the centerline penalty K_P (Table 1, 50 g, N = 40)",
    paper="Fig. 7A: the parallel constraint Eq. (1) is better satisfied, and the error "
          "against the analytical model smaller, as K_P grows",
    scene="table1-50g",
    integrator="static",
    reference="paper",
    plot="error_vs_parameter",
    overrides=("rods.catheter.nodes=40",),
    sweeps={
        "small": [Sweep(*K_P, (1e1, 1e2, 1e4), "N", "centerline penalty K_P")],
        "full": [Sweep(*K_P, (1e1, 3e1, 1e2, 3e2, 1e3, 3e3, 1e4, 1e5, 1e6, 1e7, 1e8), "N",
                       "centerline penalty K_P")],
    },
)
