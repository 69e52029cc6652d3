"""Support kinds of their own file (rodsim/core/supports.py, ``SupportKind``).

A kind that holds by springs carries its energy, force and exact Jacobian in its file
(``SupportKind.has_energy``); the registry imports every module of this package on first use
(``rodsim.core.supports.registered_support_kinds``), so a new kind is one file here, its
example in tests/test_support_kinds.py and its entry in docs/model.md (docs/architecture.md,
"How to add a support kind").
"""
