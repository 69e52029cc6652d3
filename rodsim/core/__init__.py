"""The model: scene schema and validation, rods, energy terms (numpy references and compiled
kernels), the tendon coupling, sparsity, and the assembled ``rodsim.core.model.Model``
that evaluates F(x) and ∂F/∂x. Imports nothing from the other layers (docs/architecture.md)."""
