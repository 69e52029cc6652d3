"""Fig. 18: the endpoint compliance constant K_E at K_C = 1e5 (Table 3, catheter 1)."""

from rodsim.app.study import Study, Sweep
from rodsim.studies._tendon import INTEGRATOR, K_C, K_E

STUDY = Study(
    name="fig18",
    title="catheter centerline against the endpoint compliance K_E at K_C = 1e5 N/m "
          "(Table 3, catheter 1)",
    paper="Fig. 18: a smaller K_E (a more compliant lumen end) transmits more force to the "
          "catheter: the deflection falls with K_E, almost linearly",
    scene="table3-catheter1",
    integrator=INTEGRATOR,
    overrides=("rods.catheter.nodes=30", "rods.tendon.nodes=10", f"{K_C}=1e5"),
    reference=None,
    plot="centerlines",
    sweeps={
        "small": [Sweep("K_E", K_E, (1500.0, 3000.0), "N/m", "endpoint compliance K_E")],
        "full": [Sweep("K_E", K_E, (300.0, 500.0, 700.0, 950.0, 1100.0, 1200.0, 1500.0,
                                    2000.0, 3000.0, 5000.0), "N/m",
                       "endpoint compliance K_E")],
    },
)
