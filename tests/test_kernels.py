"""Every term's compiled kernel (rodsim/core/kernels) against its numpy reference, term by term.

For every term of every contract scene (tests/test_term_contract.py), at random non-trivial
states, the kernel's accumulated force and Jacobian data must equal the numpy element
forces and Jacobians scattered through the same maps, to round-off (1e-12 of each term's
own scale). The finite-difference contract test checks the numpy reference; together they
check the kernels. The assembled model is compared on both paths too, with a load fraction
and a penalty scale, so the scale factors reach the kernels.
"""

from __future__ import annotations

import copy

import numpy as np
import pytest
from test_term_contract import CONTRACT_SCENES, SMALL_SCENES

from rodsim.core.model import Model
from rodsim.core.scene import Scene, scene_paths

ROUND_OFF = 1e-12


def both_models(name: str) -> tuple[Model, Model]:
    scene = (Scene.from_dict(copy.deepcopy(SMALL_SCENES[name])) if name in SMALL_SCENES
             else Scene.load(scene_paths()[name]))
    return Model(scene, "numpy"), Model(scene, "compiled")


def reference(model: Model, term, full: np.ndarray, jacobian_target: np.ndarray):
    """One term's numpy force and Jacobian data, scattered as the model does."""
    target = model._free_of[term.dofs]
    force = np.bincount(target.ravel(), weights=term.element_forces(full).ravel(),
                        minlength=model.n + 1)[:-1]
    data = np.zeros(model.nnz + 1)
    if term.has_jacobian:
        np.add.at(data, jacobian_target.ravel(), term.element_jacobians(full).ravel())
    return force, data[:-1]


@pytest.mark.parametrize("scene", CONTRACT_SCENES)
def test_every_kernel_matches_its_numpy_reference(scene, random_state):
    numpy_model, compiled = both_models(scene)
    rng = np.random.default_rng(list(map(ord, scene)))
    for _ in range(3):
        x = random_state(compiled, rng)
        moved = compiled.reregistered(x)
        model = moved or compiled
        for call in model._build_kernel_calls():
            index, term, arguments = call.term_index, call.term, call.arguments
            # a term on offsets (Term.offsets) is given the offset state, as the model does
            full = model.offsets(x) if term.offsets else model.full(x)
            kernel, energy = call.kernel.evaluate, call.kernel.energy
            force_target, jacobian_target = call.force_target, call.jacobian_target
            force = np.zeros(model.n + 1)
            data = np.zeros(model.nnz + 1)
            kernel(full, *arguments, 1.0, True, force, force_target, True, data,
                   jacobian_target)
            expected_force, expected_data = reference(model, term, full, jacobian_target)
            label = f"term {term.name!r} (#{index}) in {scene!r}"
            # An idle term (zero force at this state, e.g. an obstacle out of reach) must be
            # exactly idle in the kernel too; tests/test_term_contract.py makes sure every
            # term is exercised with a non-zero force somewhere.
            force_scale = np.max(np.abs(expected_force))
            np.testing.assert_allclose(force[:-1], expected_force, rtol=0,
                                       atol=ROUND_OFF * force_scale, err_msg=label)
            data_scale = max(np.max(np.abs(expected_data), initial=0.0), 1e-300)
            np.testing.assert_allclose(data[:-1], expected_data, rtol=0,
                                       atol=ROUND_OFF * data_scale, err_msg=label)
            if energy is not None and term.conservative:  # friction: no energy
                expected_energy = term.energy(full)
                assert expected_energy is not None, f"{label}: compiled energy, no reference"
                assert abs(energy(full, *arguments) - expected_energy) <= (
                    ROUND_OFF * max(abs(expected_energy), 1e-300)), label


@pytest.mark.parametrize("scene", CONTRACT_SCENES)
def test_assembled_paths_agree_with_load_and_penalty_scales(scene, random_state):
    numpy_model, compiled = both_models(scene)
    rng = np.random.default_rng(3)
    x = random_state(compiled, rng)
    penalties = {k: 0.1 for k, term in enumerate(compiled.terms) if term.penalty}
    pairs = [(numpy_model, compiled)]
    if penalties:
        pairs.append((numpy_model.with_term_scales(penalties),
                      compiled.with_term_scales(penalties)))
    for reference_model, model in pairs:
        for load in (1.0, 0.3):
            f_ref, j_ref = reference_model.evaluate(x, load)
            f, j = model.evaluate(x, load)
            np.testing.assert_allclose(f, f_ref, rtol=0, atol=ROUND_OFF * np.max(np.abs(f_ref)))
            np.testing.assert_allclose(j, j_ref, rtol=0, atol=ROUND_OFF * np.max(np.abs(j_ref)))
            np.testing.assert_array_equal(model.force(x, load), f)
            np.testing.assert_array_equal(model.jacobian_data(x, load), j)
            if model.conservative:
                expected = reference_model.energy(x, load)
                assert abs(model.energy(x, load) - expected) <= ROUND_OFF * abs(expected)


def test_kernel_constants_are_bound_by_name_to_the_kernel_signature():
    """Every term of every contract scene names exactly the constants its kernel's
    signature takes (rodsim/core/kernels/__init__.py reads them from ``evaluate``), and the
    binding follows the names, not the order in which a term lists them."""
    from rodsim.core.kernels import load_kernel, signature_constants

    seen = set()
    for scene in CONTRACT_SCENES:
        _, compiled = both_models(scene)
        for term in compiled.terms:
            kernel = load_kernel(term)
            named = dict(term.kernel_arguments())
            assert tuple(named) and set(named) == set(kernel.constants), (
                f"term {term.name!r}: kernel_arguments {sorted(named)} != kernel "
                f"{kernel.module} constants {kernel.constants}")
            if kernel.energy is not None:
                assert signature_constants(kernel.energy) == kernel.constants
            shuffled = dict(reversed(list(named.items())))
            bound = kernel.bind(shuffled)
            assert all(a is named[name] for a, name in zip(bound, kernel.constants,
                                                              strict=True))
            seen.add(kernel.module)
    assert len(seen) >= 12, sorted(seen)


def test_a_misnamed_kernel_constant_is_refused():
    from rodsim.core.kernels import load_kernel

    _, compiled = both_models("table1-50g")
    term = next(t for t in compiled.terms if t.name == "stretch")
    kernel = load_kernel(term)
    named = dict(term.kernel_arguments())
    named["rest_length"] = named.pop("rest")
    with pytest.raises(TypeError, match=r"missing constants \['rest'\].*\['rest_length'\]"):
        kernel.bind(named)


#: Shipped scenes with each lumen coupling (the paper's: table3; the conserving one: the
#: others), N_T ≠ N_C and N_T = N_C.
REGISTRATION_SCENES = ("table3-catheter1", "tendon-conserving", "four-tendons")


def _compiled_rule(term, full: np.ndarray, margin: float) -> tuple[int, np.ndarray]:
    """The compiled registration rule's answer and the parents it wrote."""
    from rodsim.core.kernels import _registration

    parents = np.full_like(term.parent, -1)
    rule = getattr(_registration, term._compiled_rule)
    answer = rule(full, *term._registration_maps, float(term.tendon.alpha),
                  float(term.tendon.beta), float(term.tendon.offset), term.parent, margin,
                  parents)
    return answer, parents


@pytest.mark.parametrize("scene", REGISTRATION_SCENES)
def test_the_compiled_registration_rule_picks_the_reference_parents(scene, random_state):
    """The lumen terms' registration rule (rodsim/core/kernels/_registration.py) against its
    numpy reference (``_switches``): a discrete choice, so the same parents exactly, with
    and without hysteresis, from random parents at random states (the tendons slid along
    the catheter by up to two segments; the parents anywhere, the rule's own or some a
    segment off them) — and the term's ``registration`` gives the same answer on both
    paths. The kernel must decide nearly every case itself (an undecided
    case, left to numpy, tests nothing), and among them cases where parents change and
    cases where none does."""
    from rodsim.core.kernels import _registration

    model = Model(Scene.load(scene_paths()[scene]), "compiled")
    rng = np.random.default_rng(list(map(ord, scene)))
    answers = []
    for _ in range(40):
        full = model.full(random_state(model, rng))
        for term in (t for t in model.terms if t.dynamic):
            slide = rng.uniform(-2.0, 2.0) * term.tendon.catheter.geometry.segment_length
            full[term._points[:, 0]] += slide
            # Parents anywhere, the rule's own, or the rule's with some a segment off.
            top = len(term.tendon.catheter.layout.quaternion_index)
            parents = term._exact(full)
            kind = rng.integers(3)
            if kind == 0:
                parents = rng.integers(0, top, len(parents))
            elif kind == 2:
                parents = np.clip(parents + rng.integers(-1, 2, len(parents)), 0, top - 1)
            term = term.registered(parents)
            for margin in (0.0, term._margin):
                answer, parents = _compiled_rule(term, full, margin)
                answers.append(answer)
                nearest, switch = term._switches(full, margin)
                if answer != _registration.UNDECIDED:
                    assert answer == (_registration.CHANGED if np.any(switch)
                                      else _registration.UNCHANGED)
                    np.testing.assert_array_equal(parents,
                                                  np.where(switch, nearest, term.parent))
            for exact in (True, False):
                compiled = term.registration(full, exact, compiled=True)
                reference = term.registration(full, exact)
                assert (compiled is None) == (reference is None)
                if reference is not None:
                    np.testing.assert_array_equal(compiled, reference)
    assert answers.count(_registration.UNDECIDED) <= len(answers) // 20, answers
    assert answers.count(_registration.CHANGED) >= 10
    assert answers.count(_registration.UNCHANGED) >= 1


@pytest.mark.parametrize("scene", REGISTRATION_SCENES)
def test_the_registration_in_blocks_is_the_registration_at_once(scene, random_state,
                                                                monkeypatch):
    """The numpy rules compare every held point with every lumen point in blocks of points
    (``REGISTRATION_BLOCK_BYTES``: a 60 000-node catheter with a 20 000-node tendon asked
    27 GiB at once): blocks of one point give the parents and switches of one block of all,
    exactly, at random states and parents."""
    import rodsim.core.terms.lumen as lumen

    model = Model(Scene.load(scene_paths()[scene]), "numpy")
    rng = np.random.default_rng(list(map(ord, scene)) + [7])
    compared, default = 0, lumen.REGISTRATION_BLOCK_BYTES
    for _ in range(10):
        full = model.full(random_state(model, rng))
        for term in (t for t in model.terms if t.dynamic):
            top = len(term.tendon.catheter.layout.quaternion_index)
            term = term.registered(rng.integers(0, top, len(term.parent)))
            answers = []
            for block_bytes in (default, 1):
                monkeypatch.setattr(lumen, "REGISTRATION_BLOCK_BYTES", block_bytes)
                blocks = len(term._blocks())
                answers.append((blocks, term._exact(full), term._switches(full, term._margin)))
            (whole, *at_once), (single, *in_blocks) = answers
            assert whole == 1 and single == len(term.parent) > 1
            np.testing.assert_array_equal(at_once[0], in_blocks[0])
            np.testing.assert_array_equal(at_once[1][0], in_blocks[1][0])
            np.testing.assert_array_equal(at_once[1][1], in_blocks[1][1])
            compared += 1
    assert compared >= 10


def test_a_registration_tie_is_left_to_the_numpy_rule():
    """At four-tendons' rest state every tendon point lies on a plane of the lumen curve
    (N_T = N_C): the compiled rule leaves the comparison to the numpy rule, and the term's
    registration is the reference's."""
    from rodsim.core.kernels import _registration

    model = Model(Scene.load(scene_paths()["four-tendons"]), "compiled")
    full = model.rest_full
    for term in (t for t in model.terms if t.dynamic):
        assert _compiled_rule(term, full, 0.0)[0] == _registration.UNDECIDED
        assert term.registration(full, True, compiled=True) is None
        assert term.registration(full, True) is None
