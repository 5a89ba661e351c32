#!/usr/bin/env python3
"""Independent references for the hose's stop (leech's `hose` module): bodies fed along a floor
until joints lock at the tubes' minimum bend radius.

Writes crates/leech/tests/data/hose.json, which crates/leech/tests/it/hose_references.rs compares
leech against.

The model is contact_references.py's (imported from it, not copied): the floating body held by
its rear cup on a floor, fed from the shortest length to its lengths at full gravity, the tubes
resting on the floor by frictionless contacts, both methods along their own feeding paths. What
is added here is the hose's stop, written as leech does not: as a term of the potential, not as
rows. A joint j of a chain turns by beta_j = phi_j - phi_(j-1) (beta_0 = phi_0 - phi0, the
clamp's direction) and bends its element of length l to the radius l / |beta_j|. The hose turns
freely (its bending is in the joint springs) up to beta_max = l / R_min, and past it against a
linear spring of stiffness k_stop per tube:

    V_stop = sum_j  k_stop,c / 2  max(0, |beta_j| - beta_max)^2        (J)

with k_stop,c = 100 k for chain A (one tube) and twice that for chain B (the side pair lumped,
as its k and m are): the estimate in leech's built-in robot (`[tube] stop_stiffness_nm_per_rad`
unset). The moment the locked hose carries at a joint is k_stop,c (|beta_j| - beta_max) (N m).
The energy stays C1 with a piecewise constant Hessian; no stored case has a joint within 1e-6 rad
of its stop on the free side, so every method sees one smooth piece near the solution.

A case is written only if contact_references' checks all pass (Newton's KKT residual below 1e-13,
SLSQP along its own path within 1e-7, stable, every contact force positive, no intrusion, force
and moment balance of the rear reaction and the contact forces against the weight to 1e-12, the
model's derivatives by central differences) and at least one joint is locked.

Run:  validation/.venv/bin/python validation/hose_references.py     (see validation/README.md)
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import contact_references as C  # noqa: E402  (the feeding path and both methods)
import holds_references as H  # noqa: E402  (the floating body)

OUT = H.ROOT / "crates" / "leech" / "tests" / "data" / "hose.json"
GENERATOR = "validation/hose_references.py"

STOP_PER_JOINT_STIFFNESS = 100.0  # k_stop / k: the built-in robot's estimate
TUBES_PER_CHAIN = (1.0, 2.0)  # chain B lumps the side pair
CLEAR_OF_KINK_RAD = 1e-6  # no joint this close to its stop, free side, in a stored case


class HoseBody(H.Body):
    """holds_references' floating body with the hose's stop in its potential."""

    def __init__(self, robot, lengths, disc="paper"):
        super().__init__(robot, lengths, disc)
        self.beta_max = robot["l"] / robot["min_bend_radius"]
        self.k_stop = [TUBES_PER_CHAIN[c] * robot["k_stop"] for c in range(self.nc)]

    def turns(self, q, c):
        """Chain c's joint turns and, per joint, the coordinates of its two angles."""
        at = self.idx(c)
        before = np.r_[self.ip + 2, at[:-1]]
        return q[at] - q[before], at, before

    def overturn(self, q, c):
        """How far each joint of chain c is past its stop (negative short of it), rad."""
        beta, _, _ = self.turns(q, c)
        return np.abs(beta) - self.beta_max

    def energy(self, q, g):
        V, grad, hess = super().energy(q, g)
        grad, hess = grad.copy(), hess.copy()
        for c in range(self.nc):
            beta, at, before = self.turns(q, c)
            over = np.abs(beta) - self.beta_max
            ks = self.k_stop[c]
            for j in np.nonzero(over > 0.0)[0]:
                s = np.sign(beta[j])
                V += 0.5 * ks * over[j] ** 2
                grad[at[j]] += ks * over[j] * s
                grad[before[j]] -= ks * over[j] * s
                a, b = at[j], before[j]
                hess[a, a] += ks
                hess[b, b] += ks
                hess[a, b] -= ks
                hess[b, a] -= ks
        return V, grad, hess

    def locked(self, q):
        """Every joint past its stop: (chain, joint, sign, point (m), moment (N m))."""
        out = []
        for c in range(self.nc):
            beta, _, _ = self.turns(q, c)
            nodes = self.nodes(q, c)
            for j, over in enumerate(np.abs(beta) - self.beta_max):
                if over > 0.0:
                    out.append(dict(chain="ab"[c], joint=j, sign=float(np.sign(beta[j])),
                                    point_m=nodes[j].tolist(), moment_nm=float(self.k_stop[c] * over)))
        return out


def robot_values():
    """contact_references' robot with the hose's minimum bend radius (from leech.toml) and the
    stop's estimated stiffness."""
    import tomllib
    robot = C.robot_values()
    t = tomllib.loads(H.ROBOT_FILE.read_text())
    robot.update(min_bend_radius=t["tube"]["min_bend_radius_m"], k_stop=STOP_PER_JOINT_STIFFNESS * robot["k"])
    return robot


FLOOR = """name = "a level floor"
[[half_plane]]          # solid below y = 0
point_m = [0.0, 0.0]
normal = [0.0, 1.0]
"""


def case_list():
    """Rear cup on the floor (contact_references' REAR), chain A fed longer than chain B until
    the body curls up off the floor and joints of chain A lock."""

    def case(name, la, lb, checks):
        return dict(name=name, scene=FLOOR, lengths=[la, lb], rear=C.REAR, checks=checks)

    return [
        case("floor_015_010", 0.15, 0.10, "chain A 50 mm longer: the body curls up, two joints of chain A "
             "locked near its tip"),
        case("floor_020_010", 0.20, 0.10, "chain A 100 mm longer: a tighter curl, joints of chain A locked"),
        case("floor_020_008", 0.20, 0.08, "chain B short: a tighter curl locks eight joints of chain A, the clamp's "
             "among them"),
        case("floor_018_006", 0.18, 0.06, "chain B short: fourteen joints locked, one of them chain B's (its stop "
             "twice as stiff: the side pair lumped)"),
        case("floor_025_008", 0.25, 0.08, "chain A 170 mm longer: chain A loops over, joints locked along it"),
    ]


def judge(case, body, scene, prob, sol, info, robot):
    """contact_references' judgement of one case, with its locked joints: at least one, none
    within CLEAR_OF_KINK_RAD of its stop on the free side."""
    out, why, _ = C.judge(case, body, scene, prob, sol, info, robot)
    q = sol[0]
    out["hose_stops"] = body.locked(q)
    # the stop's moments are internal: the balance of external forces stands as recorded
    nearest = min(float(np.min(np.abs(body.overturn(q, c)))) for c in range(body.nc))
    if not out["hose_stops"]:
        why.append("no joint locked")
    if nearest < CLEAR_OF_KINK_RAD:
        why.append(f"a joint within {nearest:.1e} rad of its stop")
    a = out["agreement"]["slsqp_vs_newton"]
    r = out["residuals"]["newton"]
    locked = " ".join(f"{s['chain']}{s['joint']}:{s['moment_nm']:.4f}" for s in out["hose_stops"])
    line = (f"{case['name']:16s} {case['lengths'][0]:.3f}/{case['lengths'][1]:.3f} {info['seconds']:5.0f} "
            f"{max(r['stationarity'], r['equality']):8.1e} {a['q']:8.1e} "
            f"{max(a['hold_multipliers'], a['contact_forces']):8.1e} {max(out['balance'].values()):8.1e} {locked}")
    return out, why, line


def main(argv):
    C.Body = HoseBody  # the feeding path builds its bodies by this name
    print(f"{'case':16s} {'lengths':>11s} {'s':>5s} {'newton':>8s} {'q diff':>8s} {'f diff':>8s} {'balance':>8s} "
          f"locked joints (N m)")
    robot = robot_values()
    C.run_cases(OUT, GENERATOR, __doc__, (robot, ("min_bend_radius", "k_stop")), case_list(), set(argv[1:]),
                np.random.default_rng(29), judge)


if __name__ == "__main__":
    main(sys.argv)
