"""Fig. 16: the lumen penalty constant K_L (Table 3, catheter 1, N_C = 30, N_T = 10)."""

from rodsim.app.study import Study, Sweep
from rodsim.studies._tendon import INTEGRATOR, K_L

STUDY = Study(
    name="fig16",
    title="catheter centerline against the lumen penalty K_L (Table 3, catheter 1)",
    paper="Fig. 16: above K_L = 1000 the lumen constraint is effectively satisfied; raising "
          "it to 1300 does little to the deformation",
    scene="table3-catheter1",
    integrator=INTEGRATOR,
    overrides=("rods.catheter.nodes=30", "rods.tendon.nodes=10"),
    reference=None,
    plot="centerlines",
    sweeps={
        "small": [Sweep("K_L", K_L, (300.0, 3000.0), "N/m", "lumen penalty K_L")],
        "full": [Sweep("K_L", K_L, (100.0, 300.0, 1000.0, 1300.0, 3000.0, 1e4, 1e5), "N/m",
                       "lumen penalty K_L")],
    },
)
