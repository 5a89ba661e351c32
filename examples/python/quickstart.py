# %% [markdown]
# # leech from Python, in five cells
#
# Run as a script (`python examples/python/quickstart.py`) or open it as a
# notebook (the `# %%` markers are cells in Jupyter, VS Code and jupytext).
# Needs only `pip install ./python` (and NumPy, which it brings).

# %% One shape: the report of `leech shape --json`, keys as attributes.
import numpy as np

import leech

robot = leech.Robot.builtin()
shape = robot.shape(0.30, 0.28)
print(shape.status, "endpoint (m):", shape.endpoint_m, "stable:", shape.stable)
print("chain A has", len(shape.chains.a.points_m), "points; the rear cup's safety:", shape.holds.rear.safety_factor)

# %% A batch: 20 000 bodies on all cores, the interpreter's lock released.
la = np.random.default_rng(1).uniform(0.06, 0.30, 20_000)
lb = np.random.default_rng(2).uniform(0.06, 0.30, 20_000)
lb[::1000] = np.nan  # a bad entry is reported, not raised
batch = robot.shapes(la, lb)
print(batch, "first failure:", batch.failures[0])
x, y = batch.endpoint_m[batch.converged].T
print(f"endpoints span x {x.min():.3f}..{x.max():.3f} m, y {y.min():.3f}..{y.max():.3f} m")

# %% Softer tubes, a wall: the same robot derived.
soft = robot.with_shape_parameter(1000).with_base_angle(90)
print("Pi = 1000 on a wall:", soft.shape(0.25, 0.20).endpoint_m)

# %% Inverse statics and the kinematic model.
answer = robot.reach(0.10, 0.15)
print("to reach (0.10, 0.15) m:", answer.status, answer.lengths_m)
print("constant curvature at the same lengths:", robot.constant_curvature(*answer.lengths_m).endpoint_m)

# %% Errors name the field, the value and what is allowed.
try:
    robot.shape(0.001, 0.2)
except leech.InputError as e:
    print(f"InputError: field={e.field!r} value={e.value!r} allowed={e.allowed!r}")
