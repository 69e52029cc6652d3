"""Self-weight on and off for the three hanging masses (docs/design.md, erratum 10)."""

from rodsim.app.study import Study, Sweep

TERMS = ["stretch", "bend_twist", "centerline", "tip_load"]
GRAVITY = Sweep("gravity", "rods.catheter.terms", (TERMS, [*TERMS, "gravity"]), "1",
                "self-weight of the catheter (gravity term)", labels=("off", "on"))
MASS = ("mass", "rods.catheter.tip_load.mass")

STUDY = Study(
    name="gravity",
    title="the catheter's self-weight (≈ 1.47 N) on and off, Table 1's three masses",
    paper="not in the paper: §3 blames part of the small-load mismatch on gravity but the "
          "model leaves self-weight out (docs/design.md, erratum 10)",
    scene="table1-50g",
    integrator="static",
    reference="exact",
    plot="centerlines",
    sweeps={
        "small": [GRAVITY, Sweep(*MASS, (0.05,), "kg", "hanging mass")],
        "full": [GRAVITY, Sweep(*MASS, (0.02, 0.05, 0.1), "kg", "hanging mass")],
    },
)
