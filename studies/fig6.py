"""Fig. 6: the three hanging masses — Cosserat model vs the analytical model vs the elastica."""

from rodsim.app.study import Study, Sweep

MASS = ("mass", "rods.catheter.tip_load.mass")

STUDY = Study(
    name="fig6",
    title="Cosserat model vs the corrected analytical model and the exact elastica "
          "(Table 1, 20/50/100 g)",
    paper="Fig. 6: CM, AM and experiment agree; tip errors within 5 % of L, below 1 % "
          "for 20 and 50 g (no experimental data here: analytic references only)",
    scene="table1-50g",
    integrator="static",
    reference="exact",
    plot="centerlines",
    sweeps={
        "small": [Sweep(*MASS, (0.02, 0.1), "kg", "hanging mass")],
        "full": [Sweep(*MASS, (0.02, 0.05, 0.1), "kg", "hanging mass")],
    },
)
