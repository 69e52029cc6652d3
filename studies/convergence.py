"""Discretisation error surface of the tendon model: N × K_P × K_L against the
constant-curvature arc (momentum-conserving coupling, docs/design.md, erratum 6)."""

from rodsim.app.study import Study, Sweep

NODES = ("rods.catheter.nodes", "rods.tendon.nodes")


def _nodes(values: tuple[int, ...]) -> Sweep:
    return Sweep("nodes", NODES, tuple((n, n) for n in values), "1",
                 "control points N (catheter = tendon)", labels=values)


def _k_p(values: tuple[float, ...]) -> Sweep:
    return Sweep("K_P", "rods.catheter.centerline.K_P", values, "N",
                 "catheter centerline penalty K_P")


def _k_l(values: tuple[float, ...]) -> Sweep:
    return Sweep("K_L", "tendons.tendon.lumen.K_L", values, "N/m^2",
                 "lumen penalty K_L per unit tendon length")


STUDY = Study(
    name="convergence",
    title="error against the constant-curvature arc over N × K_P × K_L "
          "(tendon-conserving, T = 2 N)",
    paper="not in the paper: Figs. 7 and 14–16 sweep N, K_P, K_L one at a time; here the "
          "discretisation error surface of the physical (conserving) tendon model",
    scene="tendon-conserving",
    integrator="static",
    reference="arc",
    plot="error_vs_parameter",
    sweeps={
        "small": [_nodes((10, 20)), _k_p((1e4,)), _k_l((2e5, 2e7))],
        "full": [_nodes((5, 10, 20, 40, 80)), _k_p((1e2, 1e4, 1e6)),
                 _k_l((2e6, 2e7, 2e8, 2e9))],
    },
)
