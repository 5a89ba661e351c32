"""The local Dask cluster's overhead per task: many tasks that solve
nothing (an empty batch), so what is timed is scheduling, moving a robot
and the arrays, and gathering.

    python python/benches/dask_overhead.py [--tasks 400] [--workers 2]
"""

import argparse
import time

import numpy as np

import leech
from leech import distributed


def empty_batch(robot):
    return len(robot.shapes(np.empty(0), np.empty(0)))


def main():
    p = argparse.ArgumentParser(description=__doc__)
    p.add_argument("--tasks", type=int, default=400)
    p.add_argument("--workers", type=int, default=2)
    a = p.parse_args()
    robot = leech.Robot.builtin()
    started = time.perf_counter()
    with distributed.connect(n_workers=a.workers) as client:
        print(f"local cluster of {a.workers} workers up in {time.perf_counter() - started:.2f} s")
        client.gather([client.submit(empty_batch, robot, pure=False) for _ in range(a.workers * 4)])  # warm up
        t = time.perf_counter()
        client.gather([client.submit(empty_batch, robot, pure=False) for _ in range(a.tasks)])
        spread = time.perf_counter() - t
        t = time.perf_counter()
        for _ in range(50):
            client.submit(empty_batch, robot, pure=False).result()
        one = (time.perf_counter() - t) / 50
    print(f"{a.tasks} tasks in {spread:.2f} s: {spread / a.tasks * 1e3:.2f} ms per task (throughput)")
    print(f"one task at a time: {one * 1e3:.2f} ms round trip")


if __name__ == "__main__":
    main()
