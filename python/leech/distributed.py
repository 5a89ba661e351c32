"""Design studies beyond one machine, on Dask.

A study is cut into tasks of about ``solves_per_task`` solves (10^4 by
default: an engine's task costs about a millisecond of scheduling, a solve
tens of microseconds to a millisecond, so the overhead stays near 1 %). Each
task runs the same library call a single process would, on a worker, so the
results are identical to the single-process run, not merely close:

* :func:`workspace_study`: workspace sweeps (``leech workspace``) of many
  robot designs. A design's sweep is the unit of work: its points follow one
  actuation path (warm starts from neighbour to neighbour), so a task holds
  whole designs, as many as fit in ``solves_per_task`` (a design larger than
  that is a task by itself).
* :func:`shapes`: one large batch (:meth:`leech.Robot.shapes`) cut into
  pieces whose lengths are multiples of :data:`leech.CHUNK`, where the
  batch's warm starts restart anyway.

Dask rather than Ray: ``distributed`` is pure Python from PyPI (no runtime of
its own to download), starts a two-worker cluster on a laptop or a CI
machine in about a second, and connects to a real cluster by its scheduler's
address. Pass ``client`` (a ``dask.distributed.Client``) or ``address``
(``"tcp://host:8786"``); with neither, a local cluster of ``n_workers``
processes on the loopback interface is started and closed around the study.
"""

from __future__ import annotations

import contextlib
from typing import Any, Iterator, List, Optional, Sequence, Tuple

import numpy as np

from . import CHUNK, WARM_STEP_M, WORKSPACE_COLUMNS, Robot, Shapes, _floats

#: Solves per task: a task's scheduling overhead (about a millisecond) stays
#: small next to its work.
SOLVES_PER_TASK = 10_000


def sweep_points(lengths: Tuple[float, float, float], left_longer: bool, shape_parameters: Sequence[float] = ()) -> int:
    """Grid points one design's two-chain sweep solves."""
    lo, hi, step = lengths
    n = int(np.floor((hi - lo) / step + 1e-9)) + 1
    per = n * (n + 1) // 2 if left_longer else n * n
    return per * max(1, len(shape_parameters))


def pack(sizes: Sequence[int], solves_per_task: int) -> List[List[int]]:
    """Consecutive items grouped so that each group holds at most
    `solves_per_task` solves (an item larger than that alone)."""
    if solves_per_task < 1:
        raise ValueError(f"solves_per_task: got {solves_per_task}, expected at least 1")
    tasks: List[List[int]] = []
    load = 0
    for i, size in enumerate(sizes):
        if not tasks or load + size > solves_per_task:
            tasks.append([])
            load = 0
        tasks[-1].append(i)
        load += size
    return tasks


def _sweep_designs(designs: Sequence[Tuple[str, Robot]], options: dict) -> dict:
    """One task: the designs' sweeps, one table with a ``design`` column."""
    parts = []
    for name, robot in designs:
        columns = robot.workspace(**options).columns
        columns = {"design": np.full(len(columns["la_m"]), name, dtype=object), **columns}
        parts.append(columns)
    return _concat(parts)


def _concat(parts: List[dict]) -> dict:
    names = ("design",) + WORKSPACE_COLUMNS
    if not parts:
        return {n: np.empty(0) for n in names}
    return {n: np.concatenate([np.asarray(p[n]) for p in parts]) for n in names}


def workspace_study_local(
    designs: Sequence[Tuple[str, Robot]],
    lengths: Tuple[float, float, float] = (0.05, 0.30, 0.01),
    models: Sequence[str] = ("two-chain",),
    left_longer: bool = True,
) -> dict:
    """The single-process reference of :func:`workspace_study`."""
    options = dict(lengths=lengths, models=tuple(models), left_longer=left_longer)
    return _sweep_designs(designs, options)


@contextlib.contextmanager
def connect(client: Any = None, address: Optional[str] = None, n_workers: int = 2) -> Iterator[Any]:
    """A Dask client: `client` itself, one connected to `address`, or one on
    a local cluster of `n_workers` processes (loopback only, no dashboard),
    closed on leaving."""
    if client is not None:
        yield client
        return
    from dask.distributed import Client, LocalCluster

    if address is not None:
        with Client(address) as c:
            yield c
        return
    with LocalCluster(
        n_workers=n_workers, threads_per_worker=1, host="127.0.0.1", dashboard_address=None, processes=True
    ) as cluster, Client(cluster) as c:
        yield c


def workspace_study(
    designs: Sequence[Tuple[str, Robot]],
    lengths: Tuple[float, float, float] = (0.05, 0.30, 0.01),
    models: Sequence[str] = ("two-chain",),
    left_longer: bool = True,
    client: Any = None,
    address: Optional[str] = None,
    n_workers: int = 2,
    solves_per_task: int = SOLVES_PER_TASK,
) -> dict:
    """Workspace sweeps of named robot designs ``[(name, robot), ...]`` on a
    Dask cluster: one table (a dict of arrays, the sweep CSV's columns after
    a ``design`` column), rows in the order of the designs, identical to
    :func:`workspace_study_local`."""
    options = dict(lengths=tuple(lengths), models=tuple(models), left_longer=left_longer)
    size = sweep_points(tuple(lengths), left_longer)
    tasks = pack([size] * len(designs), solves_per_task)
    with connect(client, address, n_workers) as c:
        futures = [c.submit(_sweep_designs, [designs[i] for i in t], options, pure=False) for t in tasks]
        parts = c.gather(futures)
    return _concat(parts)


def _shapes_piece(robot: Robot, la: np.ndarray, lb: np.ndarray, angles: Optional[np.ndarray], step: float) -> dict:
    out = robot.shapes(la, lb, angles, step)
    return {k: getattr(out, k) for k in _SHAPES_ARRAYS + ("reasons",)}


_SHAPES_ARRAYS = (
    "endpoint_m",
    "endpoint_angle_rad",
    "min_bend_radius_m",
    "status",
    "stable",
    "warm",
    "snapped",
    "failure_index",
    "failure_reason",
)


def shapes(
    robot: Robot,
    la: Any,
    lb: Any,
    base_angle_deg: Any = None,
    warm_step_m: float = WARM_STEP_M,
    client: Any = None,
    address: Optional[str] = None,
    n_workers: int = 2,
    solves_per_task: int = SOLVES_PER_TASK,
) -> Shapes:
    """:meth:`leech.Robot.shapes` on a Dask cluster, in pieces of whole
    chunks: the same arrays as the single-process call."""
    la, lb = _floats(la), _floats(lb)
    angles = None if base_angle_deg is None else _floats(base_angle_deg)
    if len(lb) != len(la) or (angles is not None and len(angles) != len(la)):
        # The library names the mismatched array.
        return robot.shapes(la, lb, angles, warm_step_m)
    piece = max(1, solves_per_task // CHUNK) * CHUNK
    starts = range(0, len(la), piece)
    with connect(client, address, n_workers) as c:
        futures = [
            c.submit(
                _shapes_piece,
                robot,
                la[s : s + piece],
                lb[s : s + piece],
                None if angles is None else angles[s : s + piece],
                warm_step_m,
                pure=False,
            )
            for s in starts
        ]
        parts = c.gather(futures)
    if not parts:
        return robot.shapes(la, lb, angles, warm_step_m)
    # Each piece numbers its entries and reasons from 0: shift them, and
    # keep each distinct reason once, in order of first appearance.
    reasons: dict = {}
    for s, p in zip(starts, parts):
        p["failure_index"] = p["failure_index"] + np.uint64(s)
        codes = np.array([reasons.setdefault(r, len(reasons)) for r in p["reasons"]], dtype=np.uint32)
        p["failure_reason"] = codes[p["failure_reason"]] if len(codes) else p["failure_reason"]
    columns = {k: np.concatenate([p[k] for p in parts]) for k in _SHAPES_ARRAYS}
    columns["reasons"] = list(reasons)
    return Shapes(columns)
