"""``rodsim simulate``, its trajectory archive and its figure (issue 33, "Interface";
docs/dynamics.md, docs/archive.md "Trajectory archives")."""

from __future__ import annotations

import numpy as np
import pytest

import rodsim
from rodsim.app.cli.main import main
from rodsim.io.archive import ArchiveError, read_dataset, write_dataset
from rodsim.io.archive_schema import ArchiveSchemaError, check_archive

#: table1-50g on 11 nodes, released from the equilibrium under 0.1 kg (its own mass 0.05 kg).
SMALL = ["table1-50g", "--set", "nodes=11", "--t-end", "0.05", "--output-dt", "0.01",
         "--initial", "tip_load.mass=0.1"]


def run_cli(*args: str) -> int:
    try:
        return main(list(args))
    except SystemExit as exc:  # an argparse usage error
        return int(exc.code or 0)


@pytest.fixture(scope="module")
def python_run():
    return rodsim.simulate("table1-50g", 0.05, output_dt=0.01, overrides=["nodes=11"],
                           initial={"tip_load.mass": 0.1})


def test_cli_writes_the_python_result_to_a_validated_archive(tmp_path, monkeypatch, capsys,
                                                             python_run):
    monkeypatch.chdir(tmp_path)
    assert run_cli("simulate", *SMALL) == 0
    out = capsys.readouterr().out
    archive = tmp_path / "runs" / "table1-50g-simulate.nc"  # the default output
    assert archive.exists() and (tmp_path / "runs" / "table1-50g-simulate.png").exists()
    ds = read_dataset(archive)  # validated on read (kind trajectory)
    assert ds.attrs["kind"] == "trajectory" and ds.attrs["complete"] == 1
    assert ds.attrs["success"] == 1 and ds.attrs["t_end"] == 0.05
    np.testing.assert_allclose(ds["time"].values, [0.0, 0.01, 0.02, 0.03, 0.04, 0.05],
                               rtol=0, atol=1e-15)
    np.testing.assert_array_equal(ds["position"].values, python_run.positions)
    np.testing.assert_array_equal(ds["quaternion"].values, python_run.quaternions)
    for name in ("kinetic_energy", "potential_energy", "dissipated_energy", "work"):
        np.testing.assert_array_equal(ds[name].values, getattr(python_run, name))
    assert ds["position"].dims == ("time", "node", "axis") and ds.sizes["node"] == 11
    assert list(ds["rod"].values) == ["catheter"] * 11
    # the start is the static equilibrium under 0.1 kg, at rest (an independent solve)
    held = rodsim.solve("table1-50g", "static", overrides=["nodes=11", "tip_load.mass=0.1"])
    np.testing.assert_allclose(ds["position"].values[0], held.rods["catheter"].positions,
                               rtol=0, atol=1e-9)
    assert ds["kinetic_energy"].values[0] == 0.0
    # let go with half the mass, the tip rises; energy balances (no damping, no program)
    tip = ds["position"].values[:, -1, 1]
    assert tip[-1] > tip[0]
    total = (ds["kinetic_energy"] + ds["potential_energy"] + ds["dissipated_energy"]
             - ds["work"]).values
    assert np.max(np.abs(total - total[0])) <= 1e-6 * np.max(ds["kinetic_energy"].values)
    # the summary: the tip at the end as stored, the balance, the steps
    final = ds["position"].values[-1, -1]
    assert f"({final[0]:.6g}, {final[1]:.6g}, {final[2]:.6g}) m" in out
    assert "balance error" in out and "Newton iterations" in out


def test_ida_from_the_command_line_writes_the_python_result(tmp_path, capsys):
    """--integrator ida with its tolerances: the archive holds rodsim.simulate's arrays
    bit for bit, and the summary names IDA's counts."""
    out = tmp_path / "ida.nc"
    assert run_cli("simulate", *SMALL, "--integrator", "ida", "--rtol", "1e-6", "--atol",
                   "1e-6", "--max-order", "2", "-o", str(out)) == 0
    assert "residual evaluations" in capsys.readouterr().out
    ds = read_dataset(out)
    assert ds.attrs["complete"] == 1 and ds.attrs["integrator"] == "ida"
    python = rodsim.simulate("table1-50g", 0.05, output_dt=0.01, overrides=["nodes=11"],
                             initial={"tip_load.mass": 0.1}, integrator="ida", rtol=1e-6,
                             atol=1e-6, max_order=2)
    np.testing.assert_array_equal(ds["position"].values, python.positions)
    np.testing.assert_array_equal(ds["kinetic_energy"].values, python.kinetic_energy)


def test_a_run_that_fails_part_way_is_written_incomplete(tmp_path, capsys):
    # 20 kg let go on a 0.04 s step: Newton diverges on the step from t = 0.04 s even
    # halved 8 times (on a 0.02 s step it got to t = 0.1 s, at 3.4 times the CPU)
    out = tmp_path / "fail.nc"
    code = run_cli("simulate", "table1-50g", "--set", "nodes=11", "--t-end", "0.4",
                   "--output-dt", "0.04", "--step", "0.04", "--initial", "tip_load.mass=20",
                   "-o", str(out))
    assert code == 1
    assert "incomplete" in capsys.readouterr().out
    ds = read_dataset(out)
    assert ds.attrs["complete"] == 0 and ds.attrs["success"] == 0
    assert "failed" in ds.attrs["message"] and "smaller step" in ds.attrs["message"]
    python = rodsim.simulate("table1-50g", 0.4, output_dt=0.04, step=0.04,
                             overrides=["nodes=11"], initial={"tip_load.mass": 20.0})
    assert not python.success and 2 <= len(python.times) < 11
    np.testing.assert_array_equal(ds["time"].values, python.times)
    np.testing.assert_array_equal(ds["position"].values, python.positions)


def test_plot_draws_tip_and_energies(tmp_path, python_run):
    archive = tmp_path / "t.nc"
    write_dataset(python_run.to_xarray(), archive)
    assert run_cli("plot", str(archive), "-o", str(tmp_path / "fig")) == 0
    assert (tmp_path / "fig.png").stat().st_size > 0
    assert (tmp_path / "fig.pdf").stat().st_size > 0
    pytest.importorskip("plotly")
    assert run_cli("plot", str(archive), "-o", str(tmp_path / "view"), "--format",
                   "html") == 0  # the 3D view, animated over the output times
    assert "Plotly.addFrames" in (tmp_path / "view.html").read_text(encoding="utf-8")


def test_a_broken_trajectory_archive_is_refused(tmp_path, python_run):
    ds = python_run.to_xarray()
    check_archive(ds)
    with pytest.raises(ArchiveSchemaError, match="not increasing"):
        check_archive(ds.assign_coords(time=ds["time"].values[::-1].copy()))
    with pytest.raises(ArchiveSchemaError, match="work"):
        check_archive(ds.drop_vars("work"))
    with pytest.raises(ArchiveSchemaError, match="complete"):
        check_archive(ds.assign_attrs(complete=3))
    bad = tmp_path / "bad.nc"
    ds.drop_vars("kinetic_energy").to_netcdf(bad)
    with pytest.raises(ArchiveError, match="kinetic_energy"):
        read_dataset(bad)


@pytest.mark.parametrize("args, words", [
    (("--t-end", "0"), "--t-end"),
    (("--t-end", "-1"), "--t-end"),
    (("--t-end", "0.05", "--output-dt", "0"), "--output-dt"),
    (("--t-end", "0.05", "--program", "nodes=0:11,1:12"), "nodes"),
    (("--t-end", "0.05", "--program", "tip_load.mass=0:0.1,1:-5"), "out of range"),
    (("--t-end", "0.05", "--program", "tip_load.mass=0:0.1;1"), "TIME:VALUE"),
    (("--t-end", "0.05", "--program", "tip_load.mass"), "KEY=t0:v0"),
    (("--t-end", "0.05", "--program", "radius=0:0.001,1:0.002"), "cannot vary"),
    (("--t-end", "0.05", "--integrator", "rk4"), "midpoint"),
    (("--t-end", "0.05", "--initial", "foo=1"), "--initial foo=1"),
    (("--t-end", "0.05", "--integrator", "ida", "--rtol", "0"), "--rtol"),
    (("--t-end", "0.05", "--integrator", "ida", "--atol", "1"), "--atol"),
    (("--t-end", "0.05", "--integrator", "ida", "--max-order", "6"), "--max-order"),
    (("--t-end", "0.05", "--atol", "1e-6"), "give rtol too"),
    (("--t-end", "0.05", "--max-order", "2"), "only for integrators"),
    (("--t-end", "0.05", "--initial-velocity", "1,2"), "--initial-velocity '1,2'"),
    (("--t-end", "0.05", "--initial-velocity", "1,x,2"), "VX,VY,VZ"),
    (("--t-end", "0.05", "--initial-velocity", "1,nan,2"), "three finite"),
    (("--t-end", "0.05", "--event", "contact"), "no obstacle"),
    (("--t-end", "0.05", "--integrator", "ida", "--event", "contact"), "no obstacle"),
    (("--t-end", "0.05", "--integrator", "ida", "--event", "bump"), "event 'bump'"),
])
def test_bad_input_is_one_line_and_writes_nothing(tmp_path, monkeypatch, capsys, args,
                                                   words):
    monkeypatch.chdir(tmp_path)
    assert run_cli("simulate", "table1-50g", "--set", "nodes=11", *args) == 2
    captured = capsys.readouterr()
    assert words in captured.err and len(captured.err.strip().splitlines()) == 1
    assert captured.out == ""
    assert list(tmp_path.iterdir()) == []


def test_an_interrupted_run_keeps_its_outputs(python_run):
    from rodsim.app.interrupted import Interrupted

    def stop(t: float) -> None:
        if t > 0.025:
            raise KeyboardInterrupt

    with pytest.raises(Interrupted) as caught:
        rodsim.simulate("table1-50g", 0.05, output_dt=0.01, overrides=["nodes=11"],
                        initial={"tip_load.mass": 0.1}, progress=stop)
    partial = caught.value.partial
    assert not partial.success and "interrupted after t = 0.02 s" in partial.message
    np.testing.assert_array_equal(partial.times, python_run.times[:3])
    np.testing.assert_array_equal(partial.positions, python_run.positions[:3])
    ds = partial.to_xarray()
    check_archive(ds)
    assert ds.attrs["complete"] == 0 and ds.attrs["success"] == 0


def test_ctrl_c_in_the_command_writes_the_part_done(tmp_path, monkeypatch, capsys, python_run):
    from rodsim.app.progress import ProgressPrinter

    def interrupt(self, fraction, status):
        if fraction > 0.5:
            raise KeyboardInterrupt

    monkeypatch.setattr(ProgressPrinter, "__call__", interrupt)
    out = tmp_path / "stopped.nc"
    assert run_cli("simulate", *SMALL, "-o", str(out)) == 130
    assert "marked incomplete" in capsys.readouterr().err
    ds = read_dataset(out)
    assert ds.attrs["complete"] == 0 and "interrupted" in ds.attrs["message"]
    assert ds.attrs["initial"] == "equilibrium with tip_load.mass=0.1"
    count = ds.sizes["time"]
    assert 1 <= count < 6
    np.testing.assert_array_equal(ds["position"].values, python_run.positions[:count])


#: Robots a user writes from docs/dynamics.md: (name, length m, radius m, E Pa, density kg/m3).
ROBOTS = [("steel-wire", 0.4, 1.2e-3, 207e9, 8000.0),
          ("nitinol-wire", 0.15, 0.25e-3, 60e9, 6450.0),
          ("polymer-catheter", 0.1, 1.0e-3, 20e6, 1100.0)]


@pytest.mark.parametrize("robot", ROBOTS, ids=[r[0] for r in ROBOTS])
def test_a_users_robot_with_a_program_and_damping(tmp_path, capsys, robot):
    name, length, radius, modulus, density = robot
    seed = sum(map(ord, name))
    share = np.random.default_rng(seed).uniform(0.05, 0.15)
    inertia = np.pi * radius**4 / 4
    force = share * modulus * inertia / length**2  # a tip deflection of about share*L/3
    scene = tmp_path / f"{name}.toml"
    scene.write_text(f'''name = "{name}"
[rods.wire]
length = {length}
radius = {radius}
youngs_modulus = {modulus}
density = {density}
nodes = 11
terms = ["stretch", "bend_twist", "centerline", "tip_load"]
[rods.wire.tip_load]
force = [0.0, 0.0, 0.0]
[rods.wire.damping]
retardation_time = 1e-4
drag = 0.0
''')
    # the first period of the cantilever (Euler-Bernoulli): the force ramps in over half of it
    period = 2 * np.pi * length**2 / 1.87510**2 * np.sqrt(density * np.pi * radius**2
                                                          / (modulus * inertia))
    out = tmp_path / "run.nc"
    spacing = float(f"{period / 20:.6g}")
    code = run_cli("simulate", str(scene), "--t-end", repr(20 * spacing), "--output-dt",
                   repr(spacing), "--program",
                   f"tip_load.force[1]=0:0,{period / 2:.6g}:{-force:.6g}", "-o", str(out))
    assert code == 0, capsys.readouterr().err
    ds = read_dataset(out)
    assert ds.attrs["complete"] == 1 and ds.sizes["time"] == 21
    work, dissipated = ds["work"].values, ds["dissipated_energy"].values
    assert abs(work[-1]) > 0.0 and dissipated[-1] > 0.0
    total = (ds["kinetic_energy"] + ds["potential_energy"] - ds["potential_energy"][0]
             + ds["dissipated_energy"] - ds["work"]).values
    assert np.max(np.abs(total)) <= 1e-5 * np.max(np.abs(work))
    quaternions = ds["quaternion"].values
    np.testing.assert_allclose(np.linalg.norm(quaternions, axis=-1), 1.0, atol=1e-12)
    # the tip against the first mode's response to a ramp of duration T/2 (one degree of
    # freedom, undamped: the higher modes follow the load quasi-statically)
    static = force * length**3 / (3 * modulus * inertia)
    omega, ramp = 2 * np.pi / period, period / 2
    t = ds["time"].values
    response = np.where(t <= ramp, t / ramp - np.sin(omega * t) / (omega * ramp),
                        1 - (np.sin(omega * t) - np.sin(omega * (t - ramp))) / (omega * ramp))
    tip = -ds["position"].values[:, -1, 1] / static
    # measured 1.8-2.2 % of the static deflection (N = 11, a deflection of 2-5 % of L, the
    # damping, the higher modes); a density 10 % off shifts the phase by 0.3 rad in a period
    np.testing.assert_allclose(tip, response, rtol=0, atol=0.04)
