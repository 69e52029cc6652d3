"""Fig. 17: the endpoint coupling constant K_C at K_E = 1500 (Table 3, catheter 1)."""

from rodsim.app.study import Study, Sweep
from rodsim.studies._tendon import INTEGRATOR, K_C, K_E

STUDY = Study(
    name="fig17",
    title="catheter centerline against the endpoint coupling K_C at K_E = 1500 N/m "
          "(Table 3, catheter 1)",
    paper="Fig. 17: more K_C transmits more of F_A to the catheter tip: the deflection grows "
          "with K_C and converges",
    scene="table3-catheter1",
    integrator=INTEGRATOR,
    overrides=("rods.catheter.nodes=30", "rods.tendon.nodes=10", f"{K_E}=1500"),
    reference="last",
    plot="centerlines",
    sweeps={
        "small": [Sweep("K_C", K_C, (1e3, 1e5), "N/m", "endpoint coupling K_C")],
        "full": [Sweep("K_C", K_C, (1e3, 3e3, 1e4, 3e4, 1e5, 2e5, 3e5, 1e6), "N/m",
                       "endpoint coupling K_C")],
    },
)
