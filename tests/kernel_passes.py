"""The kernels' passes a piece of code makes, by kind: (F asked, J asked) for each
evaluation of any model's kernels (``ModelEvaluation._evaluate``, past the model's memo),
for the tests that count what an evaluation in one pass saves."""

from __future__ import annotations

from typing import Any

from rodsim.core.model import Model

__all__ = ["counting_passes"]


def counting_passes(monkeypatch: Any) -> list[tuple[bool, bool]]:
    """The list every later pass of every model is appended to (``monkeypatch`` undoes the
    wrapping at the test's end)."""
    calls: list[tuple[bool, bool]] = []
    # the class whose ``_evaluate`` models call (ModelEvaluation's, unless something set
    # one on Model itself)
    owner = next(c for c in Model.__mro__ if "_evaluate" in c.__dict__)
    original = owner._evaluate

    def counted(self, x, load, force, jacobian):
        calls.append((force, jacobian))
        return original(self, x, load, force, jacobian)

    monkeypatch.setattr(owner, "_evaluate", counted)
    return calls
