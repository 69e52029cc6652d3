"""Fig. 14: catheter and tendon control points at 1:1, N_C = N_T (Table 3, catheter 1)."""

from rodsim.app.study import Study, Sweep
from rodsim.studies._tendon import INTEGRATOR, NODES


def _nodes(values: tuple[int, ...]) -> Sweep:
    return Sweep("nodes", NODES, tuple((n, n) for n in values), "1",
                 "control points N_C = N_T", labels=values)


STUDY = Study(
    name="fig14",
    title="catheter centerline for N_C = N_T (1:1), F_A = 2 N (Table 3, catheter 1)",
    paper="Fig. 14: as the number of control points grows the catheter–tendon system "
          "rapidly converges",
    scene="table3-catheter1",
    integrator=INTEGRATOR,
    reference="last",
    plot="centerlines",
    sweeps={
        "small": [_nodes((5, 10, 20))],
        "full": [_nodes((5, 10, 15, 20, 30, 40, 60, 80, 100))],
    },
)
