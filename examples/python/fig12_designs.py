"""The paper's Fig. 12 (the workspace on a wall, LA >= LB in 0.05..0.30 m)
for a grid of robot designs, on a Dask cluster.

    python examples/python/fig12_designs.py                      # local cluster, 2 workers
    python examples/python/fig12_designs.py --address tcp://scheduler:8786
    python examples/python/fig12_designs.py --check              # and compare with one process

Designs: the figure's five shape parameters times robot scales. Writes one
table (CSV, units in the column names, a `design` column first) and, when
matplotlib is installed, a picture of each design's reachable endpoints.
Needs `pip install "./python[distributed]"`.
"""

import argparse
import time

import numpy as np

import leech
from leech import distributed

SHAPE_PARAMETERS = (300.0, 1000.0, 3000.0, 5097.0, 10000.0)


def designs(scales):
    wall = leech.Robot.builtin().with_base_angle(90.0)
    return [
        (f"pi={pi:g},scale={s:g}", wall.scaled(s).with_shape_parameter(pi))
        for s in scales
        for pi in SHAPE_PARAMETERS
    ]


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--address", help="a Dask scheduler's address (default: a local cluster)")
    p.add_argument("--workers", type=int, default=2, help="local cluster's workers (default 2)")
    p.add_argument("--scales", type=float, nargs="+", default=[0.8, 1.0, 1.25], help="robot scales")
    p.add_argument("--step", type=float, default=0.01, help="grid step of both lengths (m)")
    p.add_argument("--solves-per-task", type=int, default=distributed.SOLVES_PER_TASK)
    p.add_argument("--out", default="fig12_designs.csv", help="the table (CSV)")
    p.add_argument("--png", help="a picture of the endpoints (needs matplotlib)")
    p.add_argument("--check", action="store_true", help="compare with the single-process sweep")
    a = p.parse_args()

    grid = designs(a.scales)
    lengths = (0.05, 0.30, a.step)
    started = time.perf_counter()
    table = distributed.workspace_study(
        grid, lengths, address=a.address, n_workers=a.workers, solves_per_task=a.solves_per_task
    )
    elapsed = time.perf_counter() - started
    leech.write_csv(a.out, table, list(table))
    print(f"{len(grid)} designs, {len(table['la_m'])} points in {elapsed:.1f} s -> {a.out}")

    if a.check:
        local = distributed.workspace_study_local(grid, lengths)
        same = all(np.array_equal(table[c], local[c], equal_nan=table[c].dtype.kind == "f") for c in local)
        print("identical to the single-process sweep:", same)
        if not same:
            raise SystemExit(1)

    if a.png:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, axes = plt.subplots(1, len(a.scales), figsize=(5 * len(a.scales), 5), squeeze=False)
        for ax, s in zip(axes[0], a.scales):
            for pi in SHAPE_PARAMETERS:
                rows = (table["design"] == f"pi={pi:g},scale={s:g}") & (table["status"] == "converged")
                ax.plot(table["endpoint_x_m"][rows], table["endpoint_y_m"][rows], ".", ms=2, label=f"Pi = {pi:g}")
            ax.set(title=f"scale {s:g}", xlabel="x (m)", ylabel="y (m)", aspect="equal")
        axes[0][0].legend()
        fig.savefig(a.png, dpi=120)
        print("wrote", a.png)


if __name__ == "__main__":
    main()
