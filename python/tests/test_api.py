"""The Python API gives the command line's results, raises the right
exceptions and converts arrays."""

import csv
import pickle

import numpy as np
import pytest

import leech
from conftest import ROOT, assert_same

DATA = ROOT / "examples" / "data"


@pytest.fixture(scope="module")
def robot():
    return leech.Robot.builtin()


@pytest.mark.parametrize("la,lb", [(0.30, 0.28), (0.12, 0.2), (0.25, 0.05)])
def test_shape_equals_cli(robot, cli, la, lb):
    ours = robot.shape(la, lb)
    theirs = cli("shape", "--lengths", f"{la},{lb}")
    assert_same(ours.to_dict(), theirs)
    # Attributes carry the JSON's names; arrays are NumPy arrays.
    assert ours.status == "converged"
    assert isinstance(ours.endpoint_m, np.ndarray) and ours.endpoint_m.shape == (2,)
    assert ours.chains.a.points_m.shape[1] == 2


def test_shape_in_a_scene_equals_cli(robot, cli):
    scene = leech.scenes()[0][0]
    assert_same(robot.shape(0.2, 0.18, scene=scene).to_dict(), cli("shape", "--lengths", "0.2,0.18", "--scene", scene))


def test_derived_robot_equals_cli_flags(robot, cli, tmp_path):
    tuned = robot.with_shape_parameter(1000).with_base_angle(90)
    path = tmp_path / "robot.toml"
    path.write_text(tuned.to_toml())
    assert leech.Robot.from_file(path) == tuned
    assert_same(tuned.shape(0.2, 0.15).to_dict(), cli("shape", "--robot", path, "--lengths", "0.2,0.15"))
    assert_same(
        robot.with_shape_parameter(1000).shape(0.2, 0.15).to_dict(),
        cli("shape", "--lengths", "0.2,0.15", "--shape-parameter", 1000),
    )


def test_constant_curvature_equals_cli(robot, cli):
    ours = robot.constant_curvature(0.3, 0.25)
    assert_same(ours.to_dict(), cli("shape", "--lengths", "0.3,0.25", "--model", "constant-curvature"))


def test_batch_equals_cli_shapes(robot, cli):
    la, lb = np.array([0.3, 0.12, 0.25]), np.array([0.28, 0.2, 0.05])
    batch = robot.shapes(la, lb, warm_step_m=0.0)
    assert batch.endpoint_m.shape == (3, 2)
    for i in range(3):
        theirs = cli("shape", "--lengths", f"{la[i]},{lb[i]}")
        np.testing.assert_allclose(batch.endpoint_m[i], theirs["endpoint_m"], rtol=0, atol=1e-12)
        assert abs(batch.endpoint_angle_rad[i] - theirs["endpoint_angle_rad"]) <= 1e-12
        assert batch.stable[i] == theirs["stable"] and batch.status_names()[i] == theirs["status"]


def test_batch_base_angles_equal_derived_robots(robot):
    angles = np.array([0.0, 45.0, 90.0])
    batch = robot.shapes([0.2] * 3, [0.18] * 3, base_angle_deg=angles)
    for i, a in enumerate(angles):
        assert np.array_equal(batch.endpoint_m[i], robot.with_base_angle(a).shape(0.2, 0.18).endpoint_m)


def test_workspace_equals_cli(robot, cli, tmp_path):
    out = tmp_path / "sweep.csv"
    cli("workspace", "--lengths-range", "0.05:0.3:0.025", "--left-longer", "--out", out, "--shape-parameter", "1000,5000")
    ours = robot.workspace((0.05, 0.3, 0.025), shape_parameters=(1000, 5000), models=("two-chain", "constant-curvature"), left_longer=True)
    with open(out) as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == len(ours) and list(rows[0]) == list(leech.WORKSPACE_COLUMNS)
    for name in leech.WORKSPACE_COLUMNS:
        column = ours.columns[name]
        theirs = [r[name] for r in rows]
        if column.dtype.kind == "f":
            expected = np.array([float(t) if t else np.nan for t in theirs])
            np.testing.assert_allclose(column, expected, rtol=0, atol=1e-12, equal_nan=True, err_msg=name)
        elif column.dtype.kind == "b":
            assert [str(v).lower() for v in column] == theirs, name
        else:
            assert list(column) == theirs, name


def test_reach_equals_cli(robot, cli):
    assert_same(robot.reach(0.1, 0.15).to_dict(), cli("reach", "--target", "0.1,0.15"))
    reacher = robot.reacher((0.05, 0.3, 0.01))
    assert_same(reacher.reach(0.05, 0.2, angle_deg=60).to_dict(), cli("reach", "--target", "0.05,0.2", "--angle", 60))


def test_calibration_equals_cli_from_files_and_arrays(robot, cli, tmp_path):
    sag, shapes = DATA / "tube_sag.csv", DATA / "body_shapes.csv"
    theirs = cli("calibrate", "--sag", sag, "--shapes", shapes, "--out", tmp_path / "fitted.toml")
    ours = robot.calibrate(sag, shapes)
    assert_same(ours.to_dict(), theirs)
    assert ours.fitted == leech.Robot.from_toml(ours.fitted.to_toml())
    # The same measurements as columns of arrays.
    lines = [l for l in sag.read_text().splitlines() if not l.startswith("#")]
    table = list(csv.DictReader(lines))
    columns = {k: np.array([float(r[k]) for r in table]) for k in table[0]}
    assert_same(robot.calibrate(columns, shapes).to_dict(), theirs)


def test_climb_plans_a_scenario(robot):
    name = leech.scenarios()[0][0]
    plan = robot.climb(name, time_limit_s=300)
    assert plan.status in ("reached", "impossible", "stopped")
    assert plan.scenario and isinstance(plan.steps, list)


def test_robot_round_trips(robot):
    assert pickle.loads(pickle.dumps(robot)) == robot
    assert leech.Robot.from_dict(robot.to_dict()) == robot
    assert robot.with_shape_parameter(1234).shape_parameter == pytest.approx(1234, rel=1e-12)


# Errors.


def test_input_error_carries_field_value_allowed(robot):
    with pytest.raises(leech.InputError) as e:
        robot.shape(0.001, 0.2)
    assert isinstance(e.value, ValueError)
    assert (e.value.field, e.value.value) == ("lengths[0] (LA)", "0.001")
    assert "tube length" in e.value.allowed
    with pytest.raises(leech.InputError) as e:
        robot.with_shape_parameter(float("nan"))
    assert e.value.value == "NaN"
    with pytest.raises(leech.InputError) as e:
        robot.shape(0.2, 0.2, hold="sideways")
    assert (e.value.field, e.value.value) == ("hold", "sideways")
    with pytest.raises(leech.InputError) as e:
        robot.shape(0.2, 0.2, scene="no-such-scene")
    assert e.value.field == "scene"


def test_bad_robot_files(tmp_path):
    with pytest.raises(leech.InputError) as e:
        leech.Robot.from_dict({"name": "x", "tube": {"no_such_key": 1}})
    assert "no_such_key" in str(e.value) or "missing" in str(e.value)
    bad = tmp_path / "bad.toml"
    bad.write_text("name = [")
    with pytest.raises(leech.InputError) as e:
        leech.Robot.from_file(bad)
    assert e.value.field == str(bad)
    # Files are read by the library's one reading layer: a missing one is bad input.
    with pytest.raises(leech.InputError) as e:
        leech.Robot.from_file(tmp_path / "missing.toml")
    assert e.value.field == "robot file" and "does not exist" in str(e.value)


def test_solve_error_carries_status(robot):
    # A front hold beyond chain A's reach cannot be solved.
    with pytest.raises(leech.SolveError) as e:
        robot.shape(0.1, 0.1, hold="both", front=(0.5, 0.5, 0.0))
    assert isinstance(e.value, RuntimeError)
    assert e.value.status == "out_of_reach" and e.value.residual > 0


# The batch's own contract.


def test_batch_empty(robot):
    batch = robot.shapes(np.array([]), np.array([]))
    assert len(batch) == 0 and batch.endpoint_m.shape == (0, 2) and batch.failures == []


def test_batch_reports_nan_per_entry(robot):
    la = np.array([0.2, np.nan, 0.25, 0.2])
    lb = np.array([0.18, 0.2, np.inf, 0.18])
    batch = robot.shapes(la, lb)
    assert list(batch.status_names()) == ["converged", "invalid", "invalid", "converged"]
    assert np.isnan(batch.endpoint_m[1]).all() and not batch.stable[1]
    assert batch.reason(0) is None and "NaN" in batch.reason(1) and "LB" in batch.reason(2)
    assert [f[0] for f in batch.failures] == [1, 2]
    # Entry 3 is warm-started from entry 0, across the bad ones.
    assert batch.warm[3] and not batch.warm[0]
    # Solved cold, the bad entries change nothing for the others.
    cold = robot.shapes(la, lb, warm_step_m=0)
    assert np.array_equal(cold.endpoint_m[3], robot.shapes([0.2], [0.18]).endpoint_m[0])


def test_batch_arrays_must_agree(robot):
    with pytest.raises(leech.InputError) as e:
        robot.shapes([0.2, 0.2], [0.2])
    assert e.value.field == "lb_m"
    with pytest.raises(leech.InputError) as e:
        robot.shapes([0.2], [0.2], base_angle_deg=[0.0, 1.0])
    assert e.value.field == "base_angle_deg"


def test_batch_of_a_million_stays_bounded(robot):
    import resource

    n = 1_000_000
    la, lb = np.full(n, np.nan), np.full(n, 0.18)
    la[::10] = 0.2  # one entry in ten solved (warm from the one before), the rest invalid
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss  # KiB on Linux
    batch = robot.shapes(la, lb)
    grown_mb = (resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before) / 1024
    assert len(batch) == n and int(batch.converged.sum()) == n // 10
    assert len(batch.reasons) == 1 and len(batch.failure_index) == n - n // 10
    # The outputs are about 60 MB; a failure's message per entry would be hundreds.
    assert grown_mb < 250, f"grew by {grown_mb:.0f} MB"
