"""Whether an equilibrium of a scene with obstacles is a state of rigid contact: the one rule
every integrator's result is judged by (``rodsim.solvers.stops.Equilibrium``, for `run`,
each `track` step, `fit`, `reach` and study points alike; docs/contact.md, "Validity").

A state is refused, with its reason and advice, when

- a node lies deeper inside an obstacle than the contact law's validity
  (``rodsim.core.contact_depth.depth_failure``, ``DEPTH_LIMIT`` radii): the equilibrium is
  the penalty's, not the rigid wall's (a rod settled on the far side of a wall is this);
- a rod that meets an obstacle passes through itself (``rodsim.core.self_crossing``): the
  obstacles make the scene one of solid bodies in contact, and a rod folded through itself
  is not a state a solid rod can take. rodsim has no self-contact, so nothing kept the rod
  from it; without obstacles the same state is only flagged (a coil past one turn under a
  tip moment is the model's exact answer there, tests/test_self_crossing.py);
- a rod that meets an obstacle folds at a node: two consecutive segments turn by more than
  ``MAX_TURN`` (90°, fewer than 4 segments per turn, the sampling rodsim asks of a helical
  tendon, docs/tendon.md), a kink its segments do not resolve. Measured on guidewires laid
  straight through a 90-degree vessel (the hostile family's,
  benchmarks/rodsim_bench/hostile.py): cvode and ida settled, "stable", with one node
  turning 125–155° and the tip 5–21 mm short of the lumen's path (the discretisation
  estimate 0.018–0.033 L or unavailable), where the wire that settles along the lumen
  turns at most 1.2° a node; after this rule the family's 12 tries give 11 failures and
  that one success.

The case that made the second rule: a user's guidewire whose straight rest shape crosses
its vessel's wall (152 radii deep at its tip). `static` fails there (its load steps cannot
leave the wall) and `ida` spent its budget (below); `cvode` settled, "stable", on a wire folded
through itself inside the lumen (segments 62 and 69 0.095 mm apart, radius 0.178 mm), with
25 mm of its length doubled back: a wrong success, now a failure that names the fold and,
as static's does, the crossing rest shape and the remedy (track the insertion from a state
inside). When the rest shape crosses a wall (``rest_crossings``) and the run started from
rest, the advice names it; otherwise it says what else to try.

A pseudo-dynamic run (CVODE, IDA) from such a rest shape is judged by the same rule on its
accepted states (``ThroughTheWall``), not only where it stops: once the contact has had its
chance to push the rod out (``had_its_chance``: ``RECOVERY_STEPS`` accepted steps and
``RECOVERY_PERIODS`` first-mode periods past the load ramp, or ``CRAWL_STEPS`` steps
whatever the pseudo-time), a state that is still not one of rigid contact ends the run with
the reason and advice its end would have had. The user's guidewire with `ida` spent 72.7 s
of CPU and 50 724 steps (6 min 46 s on a loaded machine) to end "stalled", its wire folded
at node 65 since step ~600; it now fails at step 512 in 3.3 s. A wire in an arc vessel
(benchmarks/default_integrator/wire-in-arc.toml) crawled at a pseudo-time of 6e-6
first-mode periods, 7 radii inside the wall, until its 300 s were spent; it now fails at
step 5 008 in 5.4 s. With the inertial formulation the rod swings: the inclined-plane
cantilever below, out of its plane by step 121, then turned a node past 90° every ~100
steps while it crawled (0.06–0.09 periods after 20 000 steps), and neither it nor the
catheter below settled within 120 s with or without the watch; the periods keep such a
transient from being judged before step 5 000. Rods that do come out were out for good by step
45–115, with `ida` and `cvode`: the inclined-plane cantilever of tests/test_contact.py, 2.7
radii through its plane at N = 10 to 80 (45–53), a catheter 18.6 radii through the outer
wall of an arc vessel (52, 71) and the one guidewire of the hostile family that comes out
of its vessel's wall (29 radii through it: 63 with ida; cvode was out at step 90, 0.102 r
deep at step 114, out again from 115) (tests/test_contact_validity.py).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from rodsim.core.contact_depth import depth_failure, rest_crossings
from rodsim.core.self_crossing import self_crossing

if TYPE_CHECKING:
    from rodsim.core.model import Model

__all__ = ["MAX_TURN", "RECOVERY_STEPS", "RECOVERY_PERIODS", "CRAWL_STEPS", "RECOVERY_STRIDE",
           "ThroughTheWall", "contact_failure", "fold_failure", "had_its_chance",
           "sharpest_turn"]

#: The largest turn [degrees] between consecutive segments of a rod that meets an obstacle
#: (module docstring).
MAX_TURN = 90.0
#: Accepted steps a pseudo-dynamic run from a rest shape through a wall gives the contact to
#: push the rod out before its states are judged (module docstring): 4.3× the most a rod that
#: came out needed (115, a guidewire 29 radii through its vessel's wall, cvode), …
RECOVERY_STEPS = 500
#: …and first-mode periods past the load ramp (module docstring): a rod given momentum (the
#: inertial formulation) swings before it settles, and may turn past ``MAX_TURN`` on the way.
RECOVERY_PERIODS = 2.0
#: Accepted steps after which a run is judged whatever its pseudo-time: one that crawls
#: through the wall (wire-in-arc: 6e-6 periods after 25 000 steps).
CRAWL_STEPS = 5000
#: A state is judged at every this many accepted steps, once the contact has had its chance.
RECOVERY_STRIDE = 16
#: The advice of a state deeper than the law, when the rest shape is clear of every wall.
DEPTH_ADVICE = "the state is not a contact with a rigid wall"
#: The advice of a folded rod, when the rest shape is clear of every wall.
FOLD_ADVICE = ("follow the load from a state clear of itself: static's load steps, or "
               "`rodsim track` of the load from a state that touches nothing; or raise the "
               "rod's nodes")


def sharpest_turn(positions: np.ndarray) -> tuple[int, float]:
    """The node of the centerline ``positions`` (N, 3) where consecutive segments turn most,
    and that turn [degrees] (0 for fewer than 3 nodes or zero-length segments)."""
    segments = np.diff(np.asarray(positions, dtype=float), axis=0)
    lengths = np.linalg.norm(segments, axis=1)
    if len(segments) < 2 or not np.all(lengths > 0.0):
        return 0, 0.0
    tangents = segments / lengths[:, None]
    cosine = np.clip(np.einsum("ij,ij->i", tangents[1:], tangents[:-1]), -1.0, 1.0)
    k = int(np.argmin(cosine))
    return k + 1, float(np.degrees(np.arccos(cosine[k])))


def fold_failure(model: Model, x: np.ndarray) -> str | None:
    """The failure reason of a state ``x`` (free coordinates) in which a rod that meets an
    obstacle passes through itself or folds at a node, or None. The rods are those of
    ``model``'s contact terms, each checked once, in the order of the terms."""
    from rodsim.core.terms.contact import Contact

    full = None
    seen: set[str] = set()
    for term in model.terms:
        if not isinstance(term, Contact) or term.rod.name in seen:
            continue
        seen.add(term.rod.name)
        if full is None:
            full = model.full(x)
        positions = full[term.dofs]
        found = self_crossing(positions, term.radius)
        if found is not None:
            return (f"{found.text(term.rod.name)}; it meets obstacle {term.obstacle.name!r}, "
                    "so the state is not one of solid bodies in contact")
        node, turn = sharpest_turn(positions)
        if turn > MAX_TURN:
            return (f"rod {term.rod.name!r} folds at node {node}: its segments turn "
                    f"{turn:.3g} degrees there (more than {MAX_TURN:g}: fewer than 4 segments "
                    f"per turn), a kink its segments do not resolve, held by obstacle "
                    f"{term.obstacle.name!r}")
    return None


def contact_failure(model: Model, x: np.ndarray, rest: Model | None = None) -> \
        tuple[str, str] | None:
    """(reason, advice) when the equilibrium ``x`` of ``model`` is not a state of rigid
    contact (module docstring), else None. ``rest``: the model whose rest shape the run
    started from (None for a run that started elsewhere, a warm start): when that rest
    shape crosses an obstacle's wall, the advice names the crossing and the remedy."""
    from rodsim.core.terms.contact import Contact

    if not any(isinstance(term, Contact) for term in model.terms):
        return None  # both tests judge the rods of contact terms only
    reason = depth_failure(model, x)
    advice = DEPTH_ADVICE
    if reason is None:
        reason, advice = fold_failure(model, x), FOLD_ADVICE
    if reason is None:
        return None
    crossings = rest_crossings(rest) if rest is not None else []
    if crossings:
        advice = "; ".join(crossings)
    return reason, advice


@dataclass(frozen=True)
class ThroughTheWall:
    """The watch over a pseudo-dynamic run that started from a rest shape through an
    obstacle's wall (module docstring): ``of`` gives one only for such a run, ``judge`` the
    (reason, advice) of an accepted state that ends it."""

    rest: Model

    @classmethod
    def of(cls, rest: Model, warm: bool) -> ThroughTheWall | None:
        """The watch of a run from the rest shape of ``rest`` (None for a warm start, or a
        rest shape clear of every wall)."""
        if warm or not rest_crossings(rest):
            return None
        return cls(rest)

    def judge(self, model: Model, x: np.ndarray, step: int,
              settled: float) -> tuple[str, str] | None:
        """(reason, advice) when the state ``x`` of ``model`` after accepted step ``step``,
        ``settled`` first-mode periods after the load ramp ended (negative within it), ends
        the run: the contact has had its chance (``had_its_chance``) and the state is still
        not one of rigid contact (``contact_failure``). None otherwise, and between the
        steps judged (every ``RECOVERY_STRIDE``)."""
        if step % RECOVERY_STRIDE or not had_its_chance(step, settled):
            return None
        failure = contact_failure(model, x, self.rest)
        if failure is None:
            return None
        reason, advice = failure
        return (f"{reason} (step {step} from a rest shape through the wall: the contact has "
                "had its chance to push the rod out)"), advice


def had_its_chance(step: int, settled: float) -> bool:
    """Whether a run from a rest shape through a wall has given the contact its chance at
    accepted step ``step``, ``settled`` first-mode periods after its load ramp ended: both
    ``RECOVERY_STEPS`` steps and ``RECOVERY_PERIODS`` periods, or ``CRAWL_STEPS`` steps
    whatever the pseudo-time (a run crawling through the wall)."""
    return step >= CRAWL_STEPS or (step >= RECOVERY_STEPS and settled >= RECOVERY_PERIODS)
