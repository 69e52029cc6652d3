"""A run in physical time with SUNDIALS IDA — adaptive, error-controlled BDF on the residual
form of rodsim/solvers/physical/dae.py — or CVODE, the same BDF on the explicit form of
rodsim/solvers/physical/ode.py (docs/dynamics.md, "IDA" and "CVODE"); one loop, one set of
options (``PhysicalTimeOptions``) for both.

IDA takes its own steps under its error test, in physical units: an absolute tolerance of
``atol`` × L on positions (L the longest rod), ``atol`` on the quaternions (radians: a
turn δθ moves q by δθ/2), ``atol`` × L ω₁ and ``atol`` × ω₁ on the velocities and body rates
(ω₁ the lowest natural angular frequency at the start), and ``rtol`` on all. Every mode
whose velocity is above these is resolved: a sudden release or load resolves the rod's
higher bending modes, and a sudden step of a tendon's tension the segments' rotation
against the shear penalty (≈ 1e8 rad/s on tdcr-two-segment: steps of 1e-8 s); a ramp of a
tenth of a period avoids it (docs/dynamics.md, "IDA"). Weighing the body rates by the
segments' radii of gyration instead (the speed they give the mass) made those steps
1500× longer but let the loosely held rates pump energy into the rod: a tip load put on
from rest gained more energy than its kinetic energy's peak in one period. ``max_order``
caps the BDF order (1–5): BDF 3–5 are not A-stable, and an undamped rod's modes sit on the
imaginary axis. The run steps one internal step at a time (SUNDIALS' one-step mode,
through rodsim/solvers/sundials_clock.py as the pseudo-time integrators do); the output
times a step spans are read from IDA's interpolating polynomial (its dense output), so
they force no step. A program's breakpoints (a table's times, where a value's slope
changes or it jumps) are hard stops (``tstop``): the solver is restarted there with the
rates the new values give, as it is when a tendon's registration changes (§4.1).
The unit quaternions hold at every step to the corrector's tolerance (the norm row of
rodsim/solvers/physical/dae.py); between steps IDA's interpolating polynomial leaves the
unit sphere by the local error (measured up to 1.4e-8 at rtol 1e-5), so an output's
quaternions are normalised (a projection of the output only: the integration goes on
from IDA's own state).

Energy (docs/dynamics.md, "Energy"), the same balance as the midpoint rule's: the kinetic
energy and the potential V(x, t) at each output time; the dissipated energy ∫ uᵀ D_t u dt
and the programs' work ∫ ∂V/∂t dt by Gauss–Legendre quadrature (three points) over each
step, split at the output times, on the dense output — ∂V/∂t as the central difference of
V at fixed x across the current piece of the programs, where the values are linear in t
(exact for a V quadratic in them: loads, tensions, a displacement's penalty); a jump of a
value at a breakpoint adds V(x, after) − V(x, before) at once. The balance's error is then
the integrator's (and the quadrature's) error.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from rodsim.core.model import Model
from rodsim.solvers.failure import SolverFailure
from rodsim.solvers.physical.coordinates import model_state
from rodsim.solvers.physical.dae import PhysicalDae
from rodsim.solvers.physical.events import EventError, EventFunctions
from rodsim.solvers.physical.fixed_step import Motion
from rodsim.solvers.physical.ode import PhysicalOde
from rodsim.solvers.physical.ode_newton import (
    BandedNewton,
    banded_newton_options,
    linear_solver,
)
from rodsim.solvers.physical.trajectory_record import Record
from rodsim.solvers.sundials_clock import Clock
from rodsim.solvers.sundials_setup import started

if TYPE_CHECKING:
    from sksundae.cvode import CVODE
    from sksundae.ida import IDA

__all__ = ["PhysicalTimeOptions", "integrate_ida", "MAX_STEPS"]

#: SUNDIALS' status of a step that ended at a root of an event function.
ROOT_RETURN = 2
#: A root within this × max(1 s, the piece's end) of the last accepted time is one already
#: reported, found again: after an interpolation (normal mode) SUNDIALS searches again from
#: the interpolated time.
DUPLICATE = 1e-12
#: What an event function's exact zero is given to SUNDIALS as, negated (the smallest
#: positive double): see :func:`_root_finding`.
EXACT_ZERO = 5e-324
#: Internal steps a run may take before it stops (with what it computed).
MAX_STEPS = 200_000
#: Gauss–Legendre nodes and weights on [0, 1] for the energy quadratures.
GAUSS_NODES = 0.5 + 0.5 * np.array([-math.sqrt(0.6), 0.0, math.sqrt(0.6)])
GAUSS_WEIGHTS = np.array([5.0, 8.0, 5.0]) / 18.0


@dataclass(frozen=True)
class PhysicalTimeOptions:
    """The settings of a run in physical time with IDA or CVODE: relative tolerance,
    absolute tolerance (relative to L, and in radians), the BDF order cap, the longest step
    [s] (0: none) and the scales L [m] and ω₁ [rad/s] (module docstring). Not the
    ``[solver.ida]`` options of the pseudo-time integrator (``rodsim.solvers.ida.IdaOptions``)."""

    rtol: float
    atol: float
    max_order: int
    max_step: float
    length: float
    omega: float


@dataclass
class _Run:
    """What the clock reads of a run: its counters (re-initialisations)."""

    counts: dict[str, float] = field(default_factory=lambda: {"reinits": 0})


def _tolerances(dae: PhysicalDae, o: PhysicalTimeOptions) -> np.ndarray:
    """The absolute tolerances in band order (module docstring)."""
    c = dae.coordinates
    atol = np.empty(dae.size)
    atol[c.positions] = o.atol * o.length
    atol[c.quaternions] = o.atol
    atol[dae.velocities] = o.atol * o.length * o.omega
    atol[dae.angles] = o.atol * o.omega
    return atol[dae.order]


class _IdaStarter:
    """IDA on ``dae`` started at (t, y[, ẏ]) in band order (the clock's integrator)."""

    name = "ida"

    def __init__(self, dae: PhysicalDae, options: PhysicalTimeOptions,
                 events: EventFunctions | None = None) -> None:
        self.dae, self.options, self.events = dae, options, events
        self.atol = _tolerances(dae, options)

    def start(self, run: Any, t: float, y: np.ndarray, yp: np.ndarray | None) -> IDA:
        from sksundae.ida import IDA  # SUNDIALS is loaded by the first run, not at import

        dae, o = self.dae, self.options
        order, place = dae.order, dae.place
        natural = y[place]
        if yp is None:  # a start or restart: the rates the forces give
            yp = dae.rates(t, natural)[order]
        lower, upper = dae.band(t, natural)

        def resfn(t: float, y: np.ndarray, yp: np.ndarray, res: np.ndarray) -> None:
            res[:] = dae.dae_residual(t, y[place], yp[place])[order]

        def jacfn(t: float, y: np.ndarray, yp: np.ndarray, res: np.ndarray, cj: float,
                  jj: np.ndarray) -> None:
            rows, cols, values = dae.band_entries(dae.jacobian(t, y[place], yp[place], cj))
            jj[:] = 0.0
            jj[rows, cols] = values

        return started("IDA", IDA, resfn, jacfn, t, y, yp, linsolver="band", lband=lower,
                       uband=upper, rtol=o.rtol, atol=self.atol, max_order=o.max_order,
                       max_step=o.max_step, **_root_finding(dae, self.events, ida=True))


class _CvodeStarter:
    """CVODE on the explicit form of ``dae``'s equations (rodsim/solvers/physical/ode.py)
    started at (t, y) in band order (the clock's integrator)."""

    name = "cvode"

    def __init__(self, dae: PhysicalDae, options: PhysicalTimeOptions,
                 events: EventFunctions | None = None) -> None:
        self.ode, self.options, self.events = PhysicalOde(dae), options, events
        self.atol = _tolerances(dae, options)

    def start(self, run: Any, t: float, y: np.ndarray, yp: np.ndarray | None) -> CVODE:
        from sksundae.cvode import CVODE  # SUNDIALS is loaded by the first run, not at import

        ode, o = self.ode, self.options
        order, place = ode.dae.order, ode.dae.place

        def rhsfn(t: float, y: np.ndarray, yp: np.ndarray) -> None:
            yp[:] = ode.rhs(t, y[place])[order]

        options = {"rtol": o.rtol, "atol": self.atol, "max_order": o.max_order,
                   "max_step": o.max_step, **_root_finding(ode.dae, self.events, ida=False)}
        if linear_solver(ode.dae.size) == "band_gmres":  # a large rod: ode_newton.py
            return started("CVODE", CVODE, rhsfn, None, t, y, linsolver="gmres",
                           **banded_newton_options(BandedNewton(ode)), **options)

        def jacfn(t: float, y: np.ndarray, fy: np.ndarray, jj: np.ndarray) -> None:
            jj[:, :] = ode.jacobian(t, y[place])[np.ix_(order, order)]

        return started("CVODE", CVODE, rhsfn, jacfn, t, y, linsolver="dense", **options)


def _root_finding(dae: PhysicalDae, events: EventFunctions | None, ida: bool
                  ) -> dict[str, Any]:
    """SUNDIALS' root-finding options for ``events``: ``eventsfn`` (IDA: (t, y, ẏ, g), CVODE:
    (t, y, g); y in band order), ``num_events``, each function's root direction (−1 a
    downward crossing), none terminal — the run loop stops at a terminal event itself
    (SUNDIALS' one-step mode ignores ``terminal``). A user's function that fails inside
    SUNDIALS' callback is kept in ``events.failure`` (the loop raises it after the step)."""
    if events is None or not len(events):
        return {}
    place = dae.place

    def values(t: float, y: np.ndarray, g: np.ndarray) -> None:
        try:
            x, v, _ = dae.split(y[place])
            g[:] = events.values(t, dae.model_at(t), x, v)
        except EventError as exc:  # a user's function: raised by the run loop after the step
            events.failure = events.failure or exc
            g[:] = 1.0
        # an exact zero at a root found and just after it is SUNDIALS' "root found at and
        # very near t" error (IDA_ILL_INPUT) on the next call, an interpolation included:
        # a zero is given as the smallest negative number instead (below the root)
        g[g == 0.0] = -EXACT_ZERO

    if ida:
        def eventsfn(t: float, y: np.ndarray, yp: np.ndarray, g: np.ndarray) -> None:
            values(t, y, g)
    else:
        def eventsfn(t: float, y: np.ndarray, g: np.ndarray) -> None:  # type: ignore[misc]
            values(t, y, g)
    eventsfn.terminal = [False] * len(events)  # type: ignore[attr-defined]
    eventsfn.direction = list(events.directions)  # type: ignore[attr-defined]
    return {"eventsfn": eventsfn, "num_events": len(events)}


STARTERS: dict[str, type[_IdaStarter] | type[_CvodeStarter]] = {"ida": _IdaStarter,
                                                                  "cvode": _CvodeStarter}


class _Models:
    """The model of time t inside the programs' piece ending at ``end`` (the values
    just before ``end`` at ``end`` itself: a jump there belongs to the next piece), with
    its tendons registered at ``registered_at`` (§4.1; the state where the
    registration last changed)."""

    def __init__(self, model_at: Callable[[float, bool], Model], end: float) -> None:
        self.model_at, self.end = model_at, end
        self.registered_at: np.ndarray | None = None
        self._registered: dict[int, tuple[Model, Model]] = {}

    def __call__(self, t: float) -> Model:
        model = self.model_at(t, t >= self.end)
        if self.registered_at is None or not model.has_registration:
            return model
        kept = self._registered.get(id(model))
        if kept is None or kept[0] is not model:
            if len(self._registered) > 64:
                self._registered.clear()
            other = model.reregistered(model_state(model, self.registered_at))
            kept = (model, model if other is None else other)
            self._registered[id(model)] = kept
        return kept[1]

    def reregister(self, t: float, x: np.ndarray) -> bool:
        """Whether the registration changes at the state ``x`` (then taken)."""
        model = self(t)
        if not model.has_registration or model.reregistered(model_state(model, x)) is None:
            return False
        self.registered_at = x.copy()
        self._registered.clear()
        return True


def _potential(model: Model, x: np.ndarray) -> float:
    return model.energy(model_state(model, x)) if model.conservative else math.nan


class _Energy:
    """The dissipated energy and the programs' work accumulated over a run (module
    docstring)."""

    def __init__(self, dae: PhysicalDae, model_at: Callable[[float, bool], Model],
                 varies: bool, difference: float = math.inf) -> None:
        self.dae, self.model_at, self.varies = dae, model_at, varies
        self.difference = difference
        self.dissipated = self.work = 0.0

    def add(self, clock: Clock, a: float, b: float, piece: tuple[float, float]) -> None:
        """∫ over [a, b] (inside the clock's last step and the programs' ``piece``)."""
        if b <= a or not (self.dae.damping.active or self.varies):
            return
        for node, weight in zip(GAUSS_NODES, GAUSS_WEIGHTS, strict=True):
            t = a + node * (b - a)
            y = clock.interpolate(t)[self.dae.place]
            x = y[:self.dae.n]
            if self.dae.damping.active:
                g = self.dae.coordinates.g_matrix(x, self.dae.n)
                u = g @ y[self.dae.n:]
                self.dissipated += weight * (b - a) * float(u @ (self.dae.damping.matrix(x)
                                                                  @ u))
            if self.varies:
                delta = min(t - piece[0], piece[1] - t, self.difference)
                rate = (_potential(self.model_at(t + delta, True), x)
                        - _potential(self.model_at(t - delta, False), x)) / (2.0 * delta)
                self.work += weight * (b - a) * rate


def integrate_ida(dae: PhysicalDae, model_at: Callable[[float, bool], Model],
                  start: Motion, output_times: Sequence[float], breaks: Sequence[float],
                  options: PhysicalTimeOptions, progress: Callable[[float], None] | None = None,
                  record: Record | None = None, solver: str = "ida",
                  events: EventFunctions | None = None, varies: bool | None = None,
                  difference: float = math.inf) -> Record:
    """Integrate from ``start`` (t = ``output_times[0]`` = 0) through every output time;
    ``model_at(t, before)`` is the model with the values at t (``before``: their values
    just before t, where a value jumps), ``breaks`` the programs' breakpoints. A failure
    ends the run: the record holds what was computed, ``success`` False and a message with
    the time and advice. ``record``: an empty record to fill (kept on interruption);
    ``solver``: ``"ida"`` (the residual form) or ``"cvode"`` (the explicit form);
    ``events``: the event functions SUNDIALS' root finding watches (rodsim/solvers/physical/
    events.py): each root's time and name go to ``record.events`` and a terminal one ends
    the run there, with an output at its time. ``varies``: whether any value varies in
    time (its work is then integrated; default: whether there are breakpoints, which a
    program of sinusoids alone has none of); ``difference``: the longest half-width [s] of
    the central difference that gives the values' rate of work (a table's pieces are
    linear, so any is exact there; a sinusoid's needs a small one)."""
    record = Record() if record is None else record
    c, n = dae.coordinates, dae.n
    ends = sorted({float(b) for b in breaks if 0.0 < b < output_times[-1]}
                  | {float(output_times[-1])})
    energy = _Energy(dae, model_at, varies=bool(breaks) if varies is None else varies,
                     difference=difference)
    pending = [float(t) for t in output_times]
    y0 = np.concatenate([start.x, start.v, start.w.ravel()])
    run = _Run()

    def add(t: float, y: np.ndarray, interpolated: bool = False) -> None:
        x, v, w = dae.split(y)
        x = x.copy()  # q on the unit sphere: interpolated, |q| is off by the local error
        q = x[c.quaternions]
        x[c.quaternions] = q / np.linalg.norm(q, axis=1)[:, None]
        record.add(t, Motion(x, v, w), c.kinetic_energy(v, w),
                   _potential(model_at(t, False), x), energy.dissipated, energy.work,
                   interpolated)

    add(pending.pop(0), y0)
    piece_start = 0.0
    models = _Models(model_at, ends[0])
    models.reregister(0.0, start.x)
    dae.model_at = models
    clock: Clock | None = None
    try:
        clock = Clock(STARTERS[solver](dae, options, events), run, y0[dae.order],
                      shift=False)
        stopped = False
        for end in ends:
            if stopped:
                break
            models.end = end
            if clock.t > piece_start:
                clock.restart()  # a breakpoint: the rates of the new values
            while clock.t < end:
                if record.steps >= MAX_STEPS:
                    raise SolverFailure(f"{solver.upper()} took {MAX_STEPS} steps without "
                                        f"reaching t = {end:.6g} s",
                                        "try the midpoint integrator or looser rtol/atol; "
                                        "a sudden load on an undamped rod excites fast modes "
                                        "that hold the steps short: ramp it (a program) or "
                                        "give the rod damping ([rods.<rod>.damping])")
                before = clock.t
                out = clock.step(end, tstop=end)
                if events is not None and events.failure is not None:
                    raise events.failure
                if not out.success:
                    detail = clock.failure_text()
                    raise SolverFailure(f"{solver.upper()} error: {out.message}"
                                        + (f" SUNDIALS: {detail}" if detail else ""),
                                        "try a looser rtol/atol, a lower max_order or the "
                                        "midpoint integrator")
                found: list[int] = []
                if out.status == ROOT_RETURN:  # an event (SUNDIALS' root finding)
                    if float(out.t) <= clock.t + DUPLICATE * max(1.0, float(end)):
                        continue  # a root reported again after an interpolation
                    found = [int(i) for i in np.flatnonzero(out.i_events[-1])]
                clock.accept(out)
                for index in found:
                    assert events is not None
                    record.events.append((clock.t, events.names[index]))
                record.steps += 0 if found else 1
                record.largest_step = max(record.largest_step, clock.t - before)
                mark = before
                while pending and pending[0] < end and pending[0] <= clock.t:
                    t = pending.pop(0)
                    energy.add(clock, mark, t, (piece_start, end))
                    mark = t
                    if t < clock.t:
                        add(t, clock.interpolate(t)[dae.place], interpolated=True)
                    else:
                        add(t, clock.y[dae.place])
                energy.add(clock, mark, clock.t, (piece_start, end))
                if progress is not None:
                    progress(clock.t)
                if not np.all(np.isfinite(clock.y)):
                    raise SolverFailure("the state is not finite", "try a tighter rtol/atol")
                if events is not None and any(events.terminal[i] for i in found):
                    if not record.times or record.times[-1] < clock.t:
                        add(clock.t, clock.y[dae.place])
                    names = ", ".join(events.names[i] for i in found if events.terminal[i])
                    record.message = f"stopped by the event ({names}) at t = {clock.t:.9g} s"
                    stopped = True
                    break
                if models.reregister(clock.t, clock.y[dae.place][:n]):
                    run.counts["reinits"] += 1  # a tendon point changed parent (§4.1)
                    clock.restart()
            if stopped:
                break
            y_end = clock.y[dae.place]
            x = y_end[:n]
            if end < ends[-1]:  # a jump of a value at the breakpoint: its work at once
                energy.work += (_potential(model_at(end, False), x)
                                - _potential(model_at(end, True), x))
            while pending and pending[0] <= end:
                add(pending.pop(0), y_end)
            piece_start = end
    except SolverFailure as exc:
        record.success = False
        advice = f"; {exc.advice}" if exc.advice else ""
        record.message = (f"failed at t = {0.0 if clock is None else clock.t:.6g} s: {exc}"
                          f"{advice} (the run's data up to there is kept)")
    finally:
        record.iterations = dae.evaluations
    return record
