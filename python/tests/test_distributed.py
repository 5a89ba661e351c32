"""The Dask adapter on a local two-worker cluster (loopback only) gives the
single-process results exactly."""

import signal

import numpy as np
import pytest

import leech
from leech import distributed

pytest.importorskip("dask.distributed")


@pytest.fixture(autouse=True)
def bounded():
    """Each test here ends within 300 s, whatever the cluster does."""

    def expire(*_):
        raise TimeoutError("a distributed test ran past 300 s")

    previous = signal.signal(signal.SIGALRM, expire)
    signal.alarm(300)
    yield
    signal.alarm(0)
    signal.signal(signal.SIGALRM, previous)


@pytest.fixture(scope="module")
def client():
    from dask.distributed import Client, LocalCluster

    with LocalCluster(
        n_workers=2, threads_per_worker=1, host="127.0.0.1", dashboard_address=None, processes=True
    ) as cluster, Client(cluster, timeout=60) as c:
        yield c


def test_pack_keeps_tasks_near_their_size():
    assert distributed.pack([4, 4, 4, 4, 4], 10) == [[0, 1], [2, 3], [4]]
    assert distributed.pack([30, 1, 1], 10) == [[0], [1, 2]]
    assert distributed.pack([], 10) == []
    assert distributed.sweep_points((0.05, 0.3, 0.025), True) == 66


def test_workspace_study_equals_single_process(client):
    wall = leech.Robot.builtin().with_base_angle(90)
    designs = [(f"pi={p}", wall.with_shape_parameter(p)) for p in (300, 1000, 5000)]
    lengths = (0.05, 0.3, 0.025)
    # 66 points per design and 100 per task: three tasks, one per design.
    spread = distributed.workspace_study(designs, lengths, client=client, solves_per_task=100)
    local = distributed.workspace_study_local(designs, lengths)
    assert list(spread) == ["design"] + list(leech.WORKSPACE_COLUMNS)
    for name in local:
        assert np.array_equal(spread[name], local[name], equal_nan=local[name].dtype.kind == "f"), name
    assert list(np.unique(spread["design"])) == sorted(n for n, _ in designs)


def test_shapes_equal_single_process(client):
    robot = leech.Robot.builtin()
    n = 3 * leech.CHUNK + 5
    la = 0.08 + 0.2 * np.arange(n) / n
    lb = 0.9 * la
    la[7] = np.nan
    spread = distributed.shapes(robot, la, lb, client=client, solves_per_task=leech.CHUNK)
    local = robot.shapes(la, lb)
    for name in ("endpoint_m", "endpoint_angle_rad", "status", "stable", "warm", "failure_index", "failure_reason"):
        assert np.array_equal(getattr(spread, name), getattr(local, name), equal_nan=True), name
    assert spread.reasons == local.reasons and spread.failures == local.failures
