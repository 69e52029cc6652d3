"""Shared settings of the tendon-catheter studies (Figs. 14–18, 22): not a study itself.

They run Table 3's scenes (paper coupling) with the paper's integrator, Eqs. (31)/(19),
h = 0.2 s, ξ = 0.9, F_A ramped over 20 steps. It stops on the same scaled force residual as
``static`` and lands on the same equilibrium (docs/studies.md compares the two on every full
grid), but on these non-conservative scenes ``static``'s Newton needs 10–30 iterations per
load step (≈ 2–5 s a point against 0.3–1.2 s).
"""

INTEGRATOR = "paper"
NODES = ("rods.catheter.nodes", "rods.tendon.nodes")
K_L = "tendons.tendon.lumen.K_L"
K_E = "tendons.tendon.endpoint_compliance.K_E"
K_C = "tendons.tendon.endpoint_coupling.K_C"
