"""Fig. 15: tendon control points N_T at N_C = 30 (Table 3, catheter 1)."""

from rodsim.app.study import Study, Sweep
from rodsim.studies._tendon import INTEGRATOR

N_T = ("tendon_nodes", "rods.tendon.nodes")

STUDY = Study(
    name="fig15",
    title="catheter centerline against the tendon's control points N_T at N_C = 30 "
          "(Table 3, catheter 1)",
    paper="Fig. 15: the tendon's control point density has practically no influence on the "
          "catheter's deformation (N_T = 10 is used from then on)",
    scene="table3-catheter1",
    integrator=INTEGRATOR,
    overrides=("rods.catheter.nodes=30",),
    reference="last",
    plot="centerlines",
    sweeps={
        "small": [Sweep(*N_T, (5, 10), "1", "tendon control points N_T")],
        "full": [Sweep(*N_T, (5, 10, 20, 30, 60, 100), "1", "tendon control points N_T")],
    },
)
