"""What a short command does not import (issue 35, "a lean cold process"): SUNDIALS'
version is read without importing scikit-sundae, and the analytic references (scipy's
integrate, optimize and special behind them) load only when a scene has a reference.

Each check runs in a fresh interpreter and reads its ``sys.modules``; none measures time.
"""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap

import pytest

#: Modules a command pays for only when it needs them.
HEAVY = ("sksundae", "scipy.integrate", "scipy.optimize", "scipy.special",
         "rodsim.core.analytic.elastica")


def _imported(code: str) -> list[str]:
    """The ``HEAVY`` modules a fresh interpreter has imported after running ``code``."""
    probe = textwrap.dedent(code) + textwrap.dedent(f"""
        import json, sys
        print(json.dumps(sorted(m for m in {HEAVY!r} if sys.modules.get(m) is not None)))
    """)
    done = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True,
                          timeout=300, check=False)
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout.splitlines()[-1])


def test_library_versions_do_not_import_scikit_sundae():
    assert _imported("""
        from rodsim.io.provenance import library_versions
        versions = library_versions()
        assert versions["sundials_version"] not in ("", "unknown"), versions
    """) == []


def test_the_sundials_version_read_from_the_package_is_the_compiled_one():
    """The text of sksundae's py_config.pxi gives the constant its extension was built with
    (and, once sksundae is imported, the constant itself is read)."""
    sksundae = pytest.importorskip("sksundae")
    from rodsim.io import provenance

    assert provenance._sundials_version_from_source() == str(sksundae.SUNDIALS_VERSION)
    assert provenance.sundials_version() == str(sksundae.SUNDIALS_VERSION)


def test_the_summary_of_a_scene_without_references_imports_no_analytic_model():
    """tdcr-two-segment (several rods) has no cantilever reference: its summary's reference
    lines are empty and no continuum model is imported."""
    assert _imported("""
        from rodsim.app.api import load_scene
        from rodsim.app.scoring import reference_lines
        import numpy as np
        assert reference_lines(load_scene("tdcr-two-segment"), np.zeros((3, 3))) == []
    """) == []


def test_a_scene_with_a_reference_still_gets_its_lines():
    """table1-50g qualifies: its reference lines are computed (the models imported then)."""
    imported = _imported("""
        import rodsim
        from rodsim.app.scoring import reference_lines
        scene = rodsim.load_scene("table1-50g", ["nodes=12"])
        lines = reference_lines(scene, rodsim.solve(scene, "static").positions())
        assert lines[0].startswith("load        α = "), lines
    """)
    assert "rodsim.core.analytic.elastica" in imported


def test_the_analytic_package_names_its_models_on_first_use():
    import rodsim.core.analytic as analytic
    from rodsim.core.analytic import exact_elastica, tendon_rod
    from rodsim.core.analytic.elastica import exact_elastica as direct

    assert exact_elastica is direct and callable(tendon_rod)
    assert set(analytic.__all__) <= set(dir(analytic))
    with pytest.raises(AttributeError):
        analytic.not_a_model  # noqa: B018


def test_a_model_named_as_its_module_stays_the_model():
    """paper_model and tendon_arc are functions of modules of the same name: importing the
    module (as rodsim.core.analytic.reference does) leaves the package's name the function."""
    import rodsim.core.analytic as analytic
    import rodsim.core.analytic.paper_model
    import rodsim.core.analytic.tendon_arc  # noqa: F401

    assert callable(analytic.paper_model) and callable(analytic.tendon_arc)
    assert analytic.paper_model is sys.modules["rodsim.core.analytic.paper_model"].paper_model


#: A whole ``rodsim`` process that reports, as it ends, which ``HEAVY`` modules it imported.
RUN_PROBE = textwrap.dedent(f"""
    import json, sys
    from rodsim.app import lean
    early = lean.fast_exit
    def report(code):
        print(json.dumps(sorted(m for m in {HEAVY + ("scipy.interpolate", "numba")!r}
                                if sys.modules.get(m) is not None)), flush=True)
        early(code)
    lean.fast_exit = report
    from rodsim.app.cli.main import main
    sys.exit(main(sys.argv[1:], process=True))
""")


def test_rodsim_run_of_a_tendon_robot_imports_only_what_it_uses(tmp_path):
    """``rodsim run tdcr-two-segment`` (its discretisation estimate included: the shape's
    splines are rodsim.core.cubic_spline's) imports neither scipy.interpolate nor
    scikit-sundae nor the analytic models, and its numpy evaluations never load numba."""
    output = tmp_path / "tdcr.nc"
    done = subprocess.run([sys.executable, "-c", RUN_PROBE, "run", "tdcr-two-segment", "-o",
                           str(output)], capture_output=True, text=True, timeout=600,
                          check=False)
    assert done.returncode == 0, done.stderr
    assert "discretis.  error ≈ " in done.stdout
    assert json.loads(done.stdout.splitlines()[-1]) == []
    assert output.exists()
