"""Batch throughput from Python: shapes per second of Robot.shapes on the
inputs of the Rust library's divan benchmark (crates/leech/benches/batch.rs),
to set beside its figures in BENCHMARKS.md.

    python python/benches/throughput.py [--samples 10]
"""

import argparse
import statistics
import time

import numpy as np

import leech

N = 4096


def scattered():
    i = np.arange(N)
    return 0.06 + 0.23 * ((i * 37 % 101) / 100.0), 0.06 + 0.23 * ((i * 53 % 97) / 96.0)


def path():
    i = np.arange(N)
    return 0.08 + 0.2 * (i / N), 0.08 + 0.15 * (i / N) + 0.005 * np.sin(i * 0.05)


def main():
    p = argparse.ArgumentParser(description=__doc__)
    p.add_argument("--samples", type=int, default=10)
    a = p.parse_args()
    robot = leech.Robot.builtin()
    for name, (la, lb), step in [("shapes_cold_4096", scattered(), 0.0), ("shapes_path_4096", path(), leech.WARM_STEP_M)]:
        times = []
        for _ in range(a.samples):
            t = time.perf_counter()
            out = robot.shapes(la, lb, warm_step_m=step)
            times.append(time.perf_counter() - t)
        assert out.converged.all()
        med = statistics.median(times)
        print(f"{name}: median {med * 1e3:.1f} ms, {N / med / 1e3:.2f} Kshapes/s (fastest {N / min(times) / 1e3:.2f})")


if __name__ == "__main__":
    main()
