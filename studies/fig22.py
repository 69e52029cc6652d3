"""Fig. 22: Table 3's three fits (K_E, K_C) of the tendon-driven catheter, F_A = 2 N."""

from rodsim.app.study import Study, Sweep
from rodsim.studies._tendon import INTEGRATOR, K_C, K_E

FITS = Sweep("fit", (K_E, K_C), ((950.0, 2e5), (1100.0, 1e5), (1200.0, 1e5)), "1",
             "Table 3 fit (K_E, K_C)", labels=("catheter 1", "catheter 2", "catheter 3"))

STUDY = Study(
    name="fig22",
    title="Table 3's three fits of the tendon-driven catheter, F_A = 2 N",
    paper="Fig. 22: the model with Table 3's fits matches three experimental catheters "
          "(no experimental data here: the fits are compared with each other only)",
    scene="table3-catheter1",
    integrator=INTEGRATOR,
    reference=None,
    plot="centerlines",
    sweeps={"small": [FITS], "full": [FITS]},
)
