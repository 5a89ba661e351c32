#!/usr/bin/env python3
"""Independent references for the body fed against a surface ahead (leech's `stance::solve_among`).

Writes crates/leech/tests/data/contact.json, which crates/leech/tests/it/contact_references.rs
compares leech against.

The model is holds_references.py's (imported from it, not copied): the floating body (link angles
of both chains, the driving unit's pose p0, phi0), the endpoint weld, the rear hold p0 = P,
phi0 = Th, and frictionless contacts: every node (link tip) keeps the tube radius r of clearance
from every solid, every link keeps r from every exposed convex polygon corner. The robot is the
built-in one (crates/leech/robots/leech.toml), its cup offsets included.

What is added here:

* The free front cup's face (leech's `FreeCups::Rest`, cases with `free_cups: "rest"`): its two
  rims x = p_A + d nu(psi) + s w e(psi), s = -1 behind and +1 ahead, with p_A the endpoint,
  psi the plate angle (chain A's last link), d = c + front_offset (the face's centre from the
  endpoint along nu of the plate) and w half the cup's diameter, each keep a signed distance
  >= 0 from every solid (no clearance: the face itself touches). In the other cases the free
  cup passes through the solids (`FreeCups::PassThrough`): only the tubes touch.
* The path the robot takes, as leech's `solve_among`: the rear cup holds at its pose; both tubes
  start at the shortest length (`[limits] tube_length_min_m`, or the shorter of the two targets)
  with gravity on and no contacts, and are fed to their lengths together, both reaching them at
  the same time (chain c at short + f (L_c - short), f from 0 to 1). Each step is solved warm
  from the last (a new link continuing its chain's last one straight) at full gravity, on every
  contact pair within 20 mm of touching (widened until no other pair comes that close), and
  within a ball of 0.15 rad (Euclidean over q) about its start (one more inequality row): a
  solve that ends on the ball found no equilibrium near the start. A step is at most 5 mm of
  the longer tube; it is halved where it fails, ends on its ball, ends unstable or turns any
  shared link by more than 0.05 rad, down to 1e-6 m (near a buckling tube's onset the branch is
  steep but continuous: at 1e-4 m steps it looked like a jump). Where even the shortest step
  finds nothing in its ball the branch has ended and the body snaps: it lands on the minimizer
  within balls about the start of twice, four times, ... the radius, each solved from the last
  one's point on its ball, until one lies inside (the balls' minimizers trace the descent from
  the start, as a trust region's path does). Snaps are logged (the lengths, the jump). The step
  doubles after a quiet step. Cases whose lengths lie on one line from the shortest length share
  one path, which stops on each of them.

Two methods share no solver code along that path:

1. Newton's method on the KKT system of the active set (holds_references' `Problem.polish`) from
   the carried state with the previous step's contact forces; where it fails (does not converge,
   ends unstable, on its ball, or with a pair it left out intruding: a contact arriving, a snap)
   SciPy `trust-constr` (exact Hessians, at most 500 iterations, 3000 at the shortest step) from
   the carried state, then Newton from its result. At a case's lengths Newton runs on until the
   KKT residual is below 1e-13 (moments over 2k, rows in m over l).
2. SciPy SLSQP (gradients only) at each step, from its own start (the short loaded body from
   both chains straight), along its own steps (the same rule), never polished by Newton; at a
   case's lengths restarted from its own solution while that lowers its KKT residual.

The stored numbers are method 1's; the largest differences of method 2 (angles and pose, the
weld's and the hold's multipliers, every contact force) are stored with them. A case is written
only if they agree to 1e-7 (rad, m; forces over the weight), Newton converged, the equilibrium is
stable (reduced Hessian positive definite), every contact force is positive, nothing intrudes
into the clearance (exact geometry: nodes against the solids, links against the corners and the
polygons' edges, the free cup's rims against the solids) and the rear reaction and the contact
forces balance the weight to 1e-12.

Run:  validation/.venv/bin/python validation/contact_references.py     (see validation/README.md)
      validation/.venv/bin/python validation/contact_references.py NAME ...   (some cases again)
"""

from __future__ import annotations

import json
import os
import sys
import time
import tomllib
from pathlib import Path

# one thread: the problems are small, and threads only fight over the cores
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402
import scipy  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
import holds_references as H  # noqa: E402  (the project's own independent model)
from holds_references import Body, ContactSet, Problem, Row, Scene, e, e_prime, nu, pose  # noqa: E402

ROOT = H.ROOT
OUT = ROOT / "crates" / "leech" / "tests" / "data" / "contact.json"
GENERATOR = "validation/contact_references.py"

FEED_STEP_M = 0.005  # longest feeding step (of the longer tube's growth)
MIN_FEED_STEP_M = 1e-6  # shortest: where even it finds no equilibrium nearby, the body snaps
JUMP_RAD = 0.05  # a step that turns a shared link by more than this is halved
BALL_RAD = 0.15  # a step's solve stays within this (rad, Euclidean over q) of its start ...
BALL_INSIDE = 0.95  # ... and must end inside this fraction of it
LANDING_BALLS = 7  # a snap's balls: up to 2^7 times the step's
TC_MAXITER = 500  # a feeding step's trust-constr iterations (six times as many at the shortest step)
SLSQP_STEP_ITERATIONS = 200  # a feeding step's SLSQP iterations (2000 at the shortest step)
SLSQP_RESTARTS = 3  # SLSQP from its own solution at a case's lengths, at most this often
FINAL_TOL = 1e-13  # the last Newton's KKT residual (moments over 2k, rows over l)
AGREE_Q = 1e-7  # method 2 against method 1: angles and pose (rad, m) ...
AGREE_FORCE = 1e-7  # ... and every multiplier and contact force, over the weight
MARGIN_M = H.MARGIN_M  # contact pairs within this of touching take part in a solve
TRACE = bool(os.environ.get("CONTACT_TRACE"))  # CONTACT_TRACE=1: print every feeding step

# Newton's tolerance for the polish along the path; the final one is tighter.
H.NEWTON_TOL = 1e-12


# ----------------------------------------------------------------------------------------------
# The robot: the built-in one, cups included
# ----------------------------------------------------------------------------------------------


def robot_values():
    """holds_references' robot values with the built-in cup's offsets, its diameter and the
    shortest tube length, from leech.toml."""
    t = tomllib.loads(H.ROBOT_FILE.read_text())
    robot = H.builtin_robot()
    robot.update(rear_offset=t["cup"]["rear_offset_m"], front_offset=t["cup"]["front_offset_m"],
                 cup_diameter=t["cup"]["diameter_m"], tube_length_min=t["limits"]["tube_length_min_m"])
    return robot


# ----------------------------------------------------------------------------------------------
# The free front cup's face
# ----------------------------------------------------------------------------------------------


def rim_point(body, q, side):
    """The front cup's rim x = p_A + d nu(psi) + s w e(psi) (s = -1 behind, +1 ahead): value,
    Jacobian (2, N) and the diagonal second derivatives (2, N) (each term in one coordinate)."""
    R = body.R
    d, w = R["c"] + R["front_offset"], 0.5 * R["cup_diameter"]
    s = (-1.0, 1.0)[side]
    x, J, Hd = body.node(q, 0, body.n[0])
    ia = body.last(0)
    psi = q[ia]
    x = x + d * nu(psi) + s * w * e(psi)
    J = J.copy()
    Hd = Hd.copy()
    J[:, ia] += d * e(psi) + s * w * e_prime(psi)  # nu' = e, e' = e_prime
    Hd[:, ia] += d * e_prime(psi) - s * w * e(psi)  # nu'' = e_prime, e_prime' = -e
    return x, J, Hd


class CupContacts(ContactSet):
    """holds_references' contact pairs of the tubes, followed (with `rest`) by the front cup's
    two rims against every solid, signed distance >= 0; and with `ball = (q0, radius)` a last
    row radius^2 - |q - q0|^2 >= 0 that keeps a feeding step's solve near its start (a solve
    that ends on it found no equilibrium nearby: a snap, or too long a step)."""

    def __init__(self, body, scene, pairs=None, rest=False, ball=None):
        super().__init__(body, scene, pairs=pairs)
        self.rest, self.ball = rest, ball
        if pairs is None and rest:
            self.pairs += [("rim", 0, side, s) for side in (0, 1) for s in scene.solids()]

    def __len__(self):
        return len(self.pairs) + (self.ball is not None)

    def near(self, q, margin, keep=None):
        rows = self.rows(q, with_hessian=False)
        kept = set(id(p) for p in keep.pairs) if keep is not None else set()
        pairs = [p for p, row in zip(self.pairs, rows) if row.value < margin or id(p) in kept]
        return CupContacts(self.body, self.scene, pairs, self.rest, self.ball)

    def without_ball(self):
        return CupContacts(self.body, self.scene, self.pairs, self.rest)

    def rows(self, q, with_hessian=True):
        tubes = [p for p in self.pairs if p[0] != "rim"]
        out = ContactSet(self.body, self.scene, pairs=tubes).rows(q, with_hessian) if tubes else []
        for _, _, side, solid in self.pairs[len(tubes):]:
            x, J, Hd = rim_point(self.body, q, side)
            dist, gx, hx, _ = H.solid_distance(solid, x)
            blocks = [(J, hx)] if with_hessian and np.any(hx) else []
            out.append(Row(dist, gx @ J, gx @ Hd, blocks, info=("rim", 0, side, 0.0, x, gx)))
        if self.ball is not None:
            centre, radius = self.ball
            d = q - centre
            out.append(Row(radius ** 2 - d @ d, -2 * d, np.full(len(q), -2.0), info=("ball", 0, 0, 0.0, None, None)))
        return out


def pair_key(pair):
    """A contact pair as two ContactSets of the same Scene share it: the kind, chain, node (link,
    rim) and the solid's (corner's) own object."""
    kind, c, i, s = pair
    return kind, c, i, id(s[1]) if isinstance(s, tuple) else id(s)


# ----------------------------------------------------------------------------------------------
# The feeding path
# ----------------------------------------------------------------------------------------------


def fed_lengths(short, lengths, f):
    return [short + f * (L - short) for L in lengths]


def carried(body, q, before, q_before):
    """`q_before` (of `before`) carried to `body`: shared links keep their angles, a new link
    continues its chain's last one, the driving unit's pose kept."""
    chains = []
    for c in range(2):
        old = q_before[before.idx(c)]
        chains.append(np.r_[old, np.full(body.n[c] - len(old), old[-1])][:body.n[c]])
    return np.concatenate(chains + [q_before[before.ip:]])


def link_jump(body, q, before, q_before):
    """The largest change of a shared link's angle (rad) between two states."""
    return max(float(np.max(np.abs(q[body.idx(c)][:m] - q_before[before.idx(c)][:m])))
               for c in range(2) for m in [min(body.n[c], before.n[c])])


class LeftTheBall(RuntimeError):
    """A step's solve ended on its ball (at `q`): no equilibrium near the step's start."""

    def __init__(self, message, q):
        super().__init__(message)
        self.q = q


def ball_check(contacts, q):
    """Raises LeftTheBall where the solve `q` ended on (or outside) the ball's boundary."""
    if contacts.ball is not None:
        centre, radius = contacts.ball
        if np.linalg.norm(q - centre) > BALL_INSIDE * radius:
            raise LeftTheBall(f"moved {np.linalg.norm(q - centre):.3f} rad of {radius} rad", q)


def intrusion(everything, q):
    return -min(r.value for r in everything.without_ball().rows(q, with_hessian=False))


def widened(body, rear, everything, q0, solve):
    """`solve(problem, q)` on the pairs of `everything` within the margin of touching at q0,
    widened and solved again until no other pair comes within the margin at the solution."""
    contacts = everything.near(q0, MARGIN_M)
    q = q0
    for _ in range(10):
        prob = Problem(body, body.R["g"], rear=rear, contacts=contacts)
        q1, lam, mu, res = solve(prob, q)
        wider = everything.near(q1, MARGIN_M, keep=contacts)
        if len(wider) == len(contacts):
            return q1, lam, mu, res, prob
        contacts, q = wider, q1
    raise RuntimeError("the contact pairs kept widening")


def carried_forces(prob, previous):
    """The previous step's contact forces on `prob`'s pairs (by pair), zero elsewhere."""
    if prob.contacts is None:
        return np.zeros(0)
    known = forces_by_pair(previous["prob"], previous["mu"]) if previous else {}
    mu = np.array([known.get(pair_key(p), 0.0) for p in prob.contacts.pairs])
    return np.r_[mu, 0.0] if prob.contacts.ball is not None else mu


class TrustConstrNewton:
    """Method 1. Each step: Newton on the KKT system from the carried state with the previous
    step's contact forces (holds_references' `Problem.polish`: the active set corrected until
    every force is positive and every other row clear). Where that fails (does not converge,
    ends unstable, off the ball or with a pair it left out intruding: a contact arriving, a
    snap), trust-constr (exact Hessians) from the carried state, then Newton from trust-constr's
    result and multipliers."""

    name = "trust-constr + Newton"

    def start(self, body, rear):
        prob = Problem(body, body.R["g"], rear=rear)
        q, lam, mu, res = prob.trust_constr(H.unloaded(body, rear))
        q, lam, mu, _, active = prob.polish(q, lam, mu)
        return q, dict(lam=lam, mu=mu, prob=prob, active=active)

    def check(self, prob, everything, q, lam, mu, active):
        ball_check(everything, q)
        if intrusion(everything, q) > 1e-12:  # a pair left out of the solve
            raise RuntimeError(f"a pair left out intrudes by {intrusion(everything, q):.1e} m")
        if prob.reduced_hessian_min(q, lam, mu, active) <= 0:
            raise RuntimeError("unstable")

    def step(self, body, q0, rear, everything, previous, last_chance=False):
        try:
            prob = Problem(body, body.R["g"], rear=rear, contacts=everything.near(q0, MARGIN_M))
            q, lam, mu, _, active = prob.polish(q0, previous["lam"], carried_forces(prob, previous))
            self.check(prob, everything, q, lam, mu, active)
            return q, dict(lam=lam, mu=mu, prob=prob, active=active, trust_constr=False)
        except (RuntimeError, np.linalg.LinAlgError) as err:
            if TRACE:
                print(f"    Newton: {str(err)[:100]}")
        maxiter = TC_MAXITER * (6 if last_chance else 1)
        # trust-constr may stop on its iteration limit short of its own tolerance (gtol 1e-8
        # N m on stiff, barely stable bodies): Newton takes it from there
        q, lam, mu, res, prob = widened(body, rear, everything, q0,
                                        lambda prob, q: prob.trust_constr(q, maxiter=maxiter, barrier=1e-6))
        ball_check(everything, q)
        q, lam, mu, _, active = prob.polish(q, lam, mu)
        self.check(prob, everything, q, lam, mu, active)
        return q, dict(lam=lam, mu=mu, prob=prob, active=active, trust_constr=True)


def within_of_a_solution(prob, x, lam, mu, tol=1e-7):
    """Whether SLSQP's point `x`, stopped on its line search (status 8) short of the KKT
    tolerances, lies within `tol` (rad, m) of a KKT point: Newton on its active set from there
    (the polish) converges and moves it no farther. The path stays SLSQP's (its point is kept);
    Newton only vouches that the point is a solution's neighbourhood, not where it ends up."""
    try:
        q, lam_n, mu_n, _, _ = prob.polish(x, lam, mu)
    except (RuntimeError, np.linalg.LinAlgError, ValueError):
        return False
    r = prob.kkt_residual(q, lam_n, mu_n)
    return bool(np.max(np.abs(q - x)) < tol and r["stationarity"] < 1e-10 and r["violation"] < 1e-12)


class Slsqp:
    """Method 2: SLSQP at each step from the carried state, on the pairs near it (widened until no
    other pair comes within the margin at its solution); its start the short body loaded from
    both chains straight."""

    name = "SLSQP"

    @staticmethod
    def solve(prob, q, maxiter=2000):
        # status 8 (no descent on the line search) is SLSQP at rounding level of its merit, or
        # stuck: once more from where it stopped (a fresh start of its quasi-Newton matrix), then
        # taken where the KKT residual says it is a solution
        for _ in range(2):
            x, lam, mu, res = prob.slsqp(q, maxiter)
            if res.status == 0:
                return x, lam, mu, res
            q = x
        r = prob.kkt_residual(x, lam, mu)
        if res.status == 8 and r["stationarity"] < 1e-8 and r["equality"] < 1e-10 and r["violation"] < 1e-10:
            return x, lam, mu, res
        if res.status == 8 and within_of_a_solution(prob, x, lam, mu):
            return x, lam, mu, res
        raise RuntimeError(f"SLSQP: {res.message}")

    @staticmethod
    def refined(prob, q, lam, mu):
        """SLSQP again from its own solution, while that lowers the KKT residual (its
        multipliers come from its quasi-Newton QP; a fresh start at the solution sharpens them)."""
        best = (q, lam, mu)
        residual = lambda x, l, m: max(prob.kkt_residual(x, l, m)[k] for k in ("stationarity", "equality"))
        for _ in range(SLSQP_RESTARTS):
            x, l, m, res = prob.slsqp(best[0])
            if residual(x, l, m) >= residual(*best):
                break
            best = (x, l, m)
        return best

    def start(self, body, rear):
        prob = Problem(body, body.R["g"], rear=rear)
        q, lam, mu, res = self.solve(prob, H.straight(body, rear[:2], rear[2]))
        return q, dict(lam=lam, mu=mu, prob=prob)

    def step(self, body, q0, rear, everything, previous, last_chance=False):
        # a step too long for the branch costs SLSQP hundreds of iterations before it fails: it
        # is halved sooner; the shortest step has all of them
        maxiter = 2000 if last_chance else SLSQP_STEP_ITERATIONS
        q, lam, mu, res, prob = widened(body, rear, everything, q0, lambda p, x: self.solve(p, x, maxiter))
        ball_check(everything, q)
        if intrusion(everything, q) > 1e-9:
            raise RuntimeError(f"SLSQP intrudes by {intrusion(everything, q):.1e} m")
        # stable on the rows that push (SLSQP's own multipliers)
        active = [i for i, (row, m) in enumerate(zip(prob.ineq(q), mu)) if m > 1e-9 and row.value < 1e-7]
        if prob.reduced_hessian_min(q, lam, mu, active) <= 0:
            raise RuntimeError("unstable")
        return q, dict(lam=lam, mu=mu, prob=prob)


def feed(robot, ray, scene, method):
    """Feeds the tubes of the cases `ray` (one scene, rear hold and lengths ratio: one path) from
    the shortest length to the longest case's lengths with `method` (see the module doc),
    stopping on every case's lengths. Returns, per case, the body, q and the last step's details,
    and a log (steps, halvings, snaps)."""
    first = ray[0]
    rear, disc, rest = first["rear"], first.get("disc", "paper"), first.get("free_cups") == "rest"
    short = shortest(robot, first)
    lengths = max((c["lengths"] for c in ray), key=lambda x: max(x))
    span = max(L - short for L in lengths)
    stops = sorted(((max(c["lengths"]) - short) / span, c["name"], c["lengths"]) for c in ray)
    body = Body(robot, [short, short], disc)
    q, detail = method.start(body, rear)
    f, h, steps, halved, steep, snaps, solved = 0.0, FEED_STEP_M, 0, 0, 0, [], {}
    by_trust_constr = 0
    while stops:
        stop, name, at = stops[0]
        f_next = stop if f + h / span > stop - 1e-9 else f + h / span
        nxt = Body(robot, at if f_next == stop else fed_lengths(short, lengths, f_next), disc)
        last_chance = h <= MIN_FEED_STEP_M * (1 + 1e-9)
        q0 = carried(nxt, q, body, q)
        snapped = False
        saved_errors = np.seterr(over="ignore", invalid="ignore")  # a diverging Newton (replaced) overflows
        try:
            try:
                ball = CupContacts(nxt, scene, rest=rest, ball=(q0, BALL_RAD))
                q_next, info = method.step(nxt, q0, rear, ball, detail, last_chance)
            except LeftTheBall as left:
                if not last_chance:
                    raise
                q_next, info = landing(method, nxt, q0, rear, scene, rest, detail, left.q)
                snapped = True
            jump = link_jump(nxt, q_next, body, q)
        except (RuntimeError, np.linalg.LinAlgError, ValueError) as err:
            if TRACE:
                print(f"  {method.name} f {f_next:.6f} h {h:.1e}: {str(err)[:100]}")
            if last_chance:
                raise RuntimeError(f"{method.name}: feeding step to {nxt.el[0].sum():.5f}/{nxt.el[1].sum():.5f} m "
                                   f"failed: {err}") from err
            h, halved = max(0.5 * h, MIN_FEED_STEP_M), halved + 1
            continue
        finally:
            np.seterr(**saved_errors)
        if TRACE:
            print(f"  {method.name} f {f_next:.6f} h {h:.1e} L {nxt.el[0].sum():.5f}/{nxt.el[1].sum():.5f} "
                  f"jump {jump:.3e} end {nxt.endpoint(q_next).round(4)} plate {q_next[nxt.last(0)]:+.3f}"
                  f"{' SNAP' if snapped else ''}")
        if jump > JUMP_RAD and not last_chance:
            h, halved = max(0.5 * h, MIN_FEED_STEP_M), halved + 1
            continue
        if snapped:
            snaps.append(dict(at_lengths_m=[float(x.sum()) for x in nxt.el], jump_rad=jump))
        elif jump > JUMP_RAD:
            steep += 1
        steps += 1
        by_trust_constr += bool(info.get("trust_constr"))
        body, q, f, detail = nxt, q_next, f_next, info
        if f_next == stop:
            solved[name] = (body, q, detail, dict(from_m=short, steps=steps, halved=halved, steep_steps=steep,
                                                  snaps=list(snaps), trust_constr_steps=by_trust_constr))
            stops.pop(0)
        if jump < 0.5 * JUMP_RAD:
            h = min(2 * h, FEED_STEP_M)
    return solved


def landing(method, body, q0, rear, scene, rest, previous, q):
    """Where the body snaps to from q0 (no equilibrium near it): the minimizers within balls about
    q0 of growing radius, each solve from the last one's point on its ball (`q`), until one lies
    inside its ball. The balls' minimizers trace the descent from q0 (as a trust region's path
    does), so a snap lands where the energy first leads, not wherever a solver's first long step
    happens to go."""
    radius = BALL_RAD
    for _ in range(LANDING_BALLS):
        radius *= 2
        try:
            return method.step(body, q, rear, CupContacts(body, scene, rest=rest, ball=(q0, radius)), previous, True)
        except LeftTheBall as left:
            q = left.q
    raise RuntimeError(f"no equilibrium within {radius} rad of the snap's start")


def shortest(robot, case):
    return min(robot["tube_length_min"], *case["lengths"])


def rays(cases, robot):
    """The cases grouped by path: the same scene, rear hold, discretization, free cups, start
    length and ratio of the tubes' growth (the path to one is a part of the path to the other)."""
    out = {}
    for c in cases:
        s = shortest(robot, c)
        la, lb = c["lengths"]
        key = (c["scene"], tuple(c["rear"]), c.get("disc", "paper"), c.get("free_cups"), s,
               round((lb - s) / (la - s), 9))
        out.setdefault(key, []).append(c)
    return list(out.values())


# ----------------------------------------------------------------------------------------------
# One case
# ----------------------------------------------------------------------------------------------


def penetration(body, scene, q, rest):
    """holds_references' exact intrusion of the tubes, and the rims' depth in the solids."""
    worst = H.penetration(body, scene, q)
    if rest:
        for side in (0, 1):
            worst = max(worst, -scene.signed_distance(rim_point(body, q, side)[0]))
    return worst


def without_ball(body, g, rear, detail):
    """A step's problem and multipliers without its ball row (inactive at a step's solution)."""
    contacts = detail["prob"].contacts
    mu = detail["mu"]
    if contacts is not None and contacts.ball is not None:
        assert mu[-1] < 1e-9, mu[-1]
        contacts, mu = contacts.without_ball(), mu[:-1]
    return Problem(body, g, rear=rear, contacts=contacts), detail["lam"], mu


def forces_by_pair(prob, mu):
    if prob.contacts is None:
        return {}
    return {pair_key(p): float(m) for p, m in zip(prob.contacts.pairs, mu)}


def solve_ray(ray, robot, rng):
    """Both methods along the ray's path; per case the Newton state, its checks and method 2's
    differences."""
    scene = Scene(ray[0]["scene"])
    rear, g = ray[0]["rear"], robot["g"]
    t0 = time.time()
    one = feed(robot, ray, scene, TrustConstrNewton())
    t1 = time.time() - t0
    t0 = time.time()
    two = feed(robot, ray, scene, Slsqp())
    t2 = time.time() - t0
    out = []
    longest = max(ray, key=lambda c: max(c["lengths"]))
    for case in ray:
        body, q, d1, log1 = one[case["name"]]
        body2, q2, d2, log2 = two[case["name"]]
        assert body2.n == body.n
        prob, lam, mu = without_ball(body, g, rear, d1)
        # the last Newton, tighter
        saved, H.NEWTON_TOL = H.NEWTON_TOL, FINAL_TOL
        try:
            q, lam, mu, its, active = prob.polish(q, lam, mu)
        finally:
            H.NEWTON_TOL = saved
        prob2, lam2, mu2 = without_ball(body2, g, rear, d2)
        q2, lam2, mu2 = Slsqp.refined(prob2, q2, lam2, mu2)
        # forces on the same pairs (a pair one method left out carries nothing there)
        f1, f2 = forces_by_pair(prob, mu), forces_by_pair(prob2, mu2)
        force_diff = max((abs(f1.get(k, 0.0) - f2.get(k, 0.0)) for k in set(f1) | set(f2)), default=0.0)
        agreement = dict(q=float(np.max(np.abs(q2 - q))), hold_multipliers=float(np.max(np.abs(lam2 - lam))),
                         contact_forces=force_diff)
        info = dict(
            residuals=dict(newton=prob.kkt_residual(q, lam, mu), slsqp=prob2.kkt_residual(q2, lam2, mu2)),
            agreement=dict(slsqp_vs_newton=agreement),
            reduced_hessian_min=prob.reduced_hessian_min(q, lam, mu, active),
            newton_iterations=its,
            # the model's derivatives, once per path (on its longest case's rows)
            derivative_check=H.check_derivatives(prob, q, rng) if case is longest else None,
            feeding=dict(step_max_m=FEED_STEP_M, step_min_m=MIN_FEED_STEP_M, jump_rad=JUMP_RAD, ball_rad=BALL_RAD,
                         shared_with=[c["name"] for c in ray if c is not case],
                         trust_constr_newton=dict(log1, seconds_for_the_path=t1),
                         slsqp=dict(log2, seconds_for_the_path=t2)),
            seconds=(t1 + t2) / len(ray),
        )
        out.append((case, body, scene, prob, (q, lam, mu, active), info))
    return out


def record(case, robot, body, scene, prob, sol, info):
    """The case in holds.json's schema (rear hold, contacts), with this script's checks."""
    q, lam, mu, active = sol
    ip = body.ip
    p0, phi0 = q[ip:ip + 2], q[ip + 2]
    W = body.weight()
    rest = case.get("free_cups") == "rest"
    out = dict(
        name=case["name"],
        checks=case["checks"],
        robot="builtin",
        discretization=case.get("disc", "paper"),
        free_cups="rest" if rest else "pass_through",
        lengths_m=case["lengths"],
        elements=body.n,
        hold="rear",
        rear=dict(point_m=list(case["rear"][:2]), angle_rad=case["rear"][2]),
        front=None,
        scene_toml=case["scene"],
        **H.state_fields(body, q, lam),
        rear_reaction=dict(force_n=lam[3:5].tolist(), moment_nm=float(lam[5])),
        front_reaction=None,
    )
    contacts = []
    rows = prob.contacts.rows(q, with_hessian=False)
    for i in active:
        kind, c, j, s, x, n = rows[i].info
        if kind == "rim":
            chain, node, frac = "front_cup", j, 0.0
        else:
            chain = "ab"[c]
            node, frac = (j, 0.0) if kind == "node" else ((j - 1, s) if 0 < s < 1 else (j - 1 + int(s), 0.0))
        contacts.append(dict(chain=chain, node=int(node), fraction=float(frac), point_m=x.tolist(),
                             normal=n.tolist(), force_n=float(mu[i])))
    out["contacts"] = contacts
    out["fixed_nodes"] = []
    # force and moment balance (about the origin) of the rear reaction and the contact forces
    F = np.array(out["rear_reaction"]["force_n"])
    M = out["rear_reaction"]["moment_nm"] + H.cross(p0, F)
    for cf in contacts:
        f = cf["force_n"] * np.array(cf["normal"])
        F += f
        M += H.cross(np.array(cf["point_m"]), f)
    xg = out["centre_of_mass_m"][0]
    out["balance"] = dict(force_x_rel=float(abs(F[0]) / W), force_y_rel=float(abs(F[1] - W) / W),
                          moment_rel=float(abs(M - xg * W) / (W * 0.3)))
    out["branch"] = H.branch_of(body, q, case)
    out["penetration_m"] = float(penetration(body, scene, q, rest))
    out["reduced_hessian_min"] = info["reduced_hessian_min"]
    out["stable"] = bool(info["reduced_hessian_min"] > 0)
    for key in ("residuals", "agreement", "newton_iterations", "derivative_check", "feeding"):
        out[key] = info[key]
    return out


# ----------------------------------------------------------------------------------------------
# Cases
# ----------------------------------------------------------------------------------------------

FLOOR_AND_WALL = """name = "a floor and a wall 0.10 m ahead of the rear cup"
[[half_plane]]          # the floor: solid below y = 0
point_m = [0.0, 0.0]
normal = [0.0, 1.0]
[[half_plane]]          # the wall: solid at x >= 0.35
point_m = [0.35, 0.0]
normal = [-1.0, 0.0]
"""


def floor_and_step(top):
    return f"""name = "a floor and a step {1000 * top:.0f} mm high 0.10 m ahead of the rear cup"
[[half_plane]]          # the floor: solid below y = 0
point_m = [0.0, 0.0]
normal = [0.0, 1.0]
[[polygon]]             # the step (counter-clockwise; its lower corners lie in the floor)
points_m = [[0.35, -0.10], [1.35, -0.10], [1.35, {top!r}], [0.35, {top!r}]]
"""


STEP_60 = floor_and_step(0.06)
STEP_30 = floor_and_step(0.03)

# The rear cup's face on the floor: p0 = (0.25, b + rear_offset), heading 0 (chain B below A).
REAR = pose(0.25, 0.032, 0)


def case_list():
    """Each case: name, what it checks, lengths (m), the scene, the rear hold (all REAR) and
    whether the free front cup rests on the solids. Cases whose lengths lie on one line from the
    shortest length share one feeding path (`rays`)."""

    def case(name, scene, la, lb, checks, **extra):
        return dict(name=name, scene=scene, lengths=[la, lb], rear=REAR, checks=checks, **extra)

    wall, step60, step30 = FLOOR_AND_WALL, STEP_60, STEP_30
    head_on = ("equal tubes fed head-on into the wall: the tips meet it, the body buckles upwards and "
               "climbs it, the plate turning up (two snaps on the way)")
    nosing = "the 60 mm step's face stops the tips, the body rides up over the nosing corner"
    return [
        case("wall_016_016", wall, 0.16, 0.16, head_on + "; chain B's tip node on the wall"),
        case("wall_020_020", wall, 0.20, 0.20, head_on + "; chain B's last link flat on the wall (two nodes)"),
        case("wall_024_024", wall, 0.24, 0.24, head_on + "; chain A bulges into the wall too (three contacts)"),
        case("wall_028_028", wall, 0.28, 0.28, head_on + "; chain A and three nodes of chain B on the wall"),
        case("wall_018_021", wall, 0.18, 0.21, "chain B longer: the body curls up before the tips reach the wall "
             "and slides up it, three nodes of chain B touching"),
        case("wall_020_022", wall, 0.20, 0.22, "chain B 20 mm longer: chain B's last two nodes on the wall"),
        case("step60_018_018", step60, 0.18, 0.18, nosing + ": both chains' links rest on the corner between nodes"),
        case("step60_022_022", step60, 0.22, 0.22, nosing + ", further out: both links on the corner"),
        case("step60_026_026", step60, 0.26, 0.26, nosing + ": chain A's link barely touching (0.09 N)"),
        case("step60_024_026", step60, 0.24, 0.26, "chain B longer: the body curls up the step's face and over "
             "the nosing, one link of chain B on the corner"),
        case("step30_022_022", step30, 0.22, 0.22, "equal tubes over a 30 mm step: chain B's link on the nosing "
             "corner and its tip node on the step's top"),
        case("step30_024_026", step30, 0.24, 0.26, "chain B longer over the 30 mm step: a link of chain B on the "
             "nosing corner"),
        case("rest_wall_016_017", wall, 0.16, 0.17, "the free front cup's face rests on the wall: both rims touch, "
             "the tubes clear", free_cups="rest"),
        case("rest_wall_026_029", wall, 0.26, 0.29, "the front cup's face on the wall by one rim and chain B's "
             "node on it", free_cups="rest"),
        case("rest_wall_020_020", wall, 0.20, 0.20, "equal tubes head-on with the front cup's face resting: the "
             "face ends flat on the wall (both rims)", free_cups="rest"),
    ]


def problems(out):
    """Why a case may not be written (empty: it may)."""
    r, a = out["residuals"]["newton"], out["agreement"]["slsqp_vs_newton"]
    checks = [
        (max(r["stationarity"], r["equality"], r["violation"], r["complementarity"]) < FINAL_TOL, f"Newton {r}"),
        (r["negative_force"] == 0.0 and all(c["force_n"] > 0 for c in out["contacts"]), "a force is not positive"),
        (out["stable"], f"unstable ({out['reduced_hessian_min']:.2e})"),
        (out["penetration_m"] < 1e-12, f"intrudes by {out['penetration_m']:.1e} m"),
        (max(out["balance"].values()) < 1e-12, f"balance {out['balance']}"),
        (a["q"] < AGREE_Q and max(a["hold_multipliers"], a["contact_forces"]) < AGREE_FORCE * out["weight_n"],
         f"the methods differ: {a}"),
        (out["derivative_check"] is None or out["derivative_check"] < 1e-5, f"derivative check {out['derivative_check']}"),
    ]
    return [why for ok, why in checks if not ok]


def judge(case, body, scene, prob, sol, info, robot):
    """One solved case: its record, why it may not be written, and its line of the table."""
    out = record(case, robot, body, scene, prob, sol, info)
    r, a = out["residuals"], out["agreement"]["slsqp_vs_newton"]
    fed = out["feeding"]["trust_constr_newton"]
    touching = " ".join(f"{c['chain']}{c['node']}{'+%.2f' % c['fraction'] if c['fraction'] else ''}:"
                        f"{c['force_n']:.3f}" for c in out["contacts"])
    line = (f"{case['name']:24s} {case['lengths'][0]:.3f}/{case['lengths'][1]:.3f} "
            f"{'rest' if out['free_cups'] == 'rest' else 'pass':>4s} {info['seconds']:5.0f} "
            f"{max(r['newton']['stationarity'], r['newton']['equality']):8.1e} "
            f"{r['slsqp']['stationarity']:8.1e} {a['q']:8.1e} {max(a['hold_multipliers'], a['contact_forces']):8.1e} "
            f"{out['reduced_hessian_min']:8.1e} {max(out['balance'].values()):8.1e} {out['penetration_m']:8.1e} "
            f"{len(fed['snaps']):5d}  {touching}")
    return out, problems(out), line


def main(argv):
    print(f"{'case':24s} {'lengths':>11s} {'cups':>4s} {'s':>5s} {'newton':>8s} {'slsqp':>8s} {'q diff':>8s} "
          f"{'f diff':>8s} {'min eig':>8s} {'balance':>8s} {'pen':>8s} snaps  contacts (N)")
    robot = robot_values()
    run_cases(OUT, GENERATOR, __doc__, (robot, ()), case_list(), set(argv[1:]), np.random.default_rng(11), judge)


def run_cases(out_path, generator, doc, robot_and_keys, cases, only, rng, judge_case):
    """Solves the rays of `cases` whose cases are named in `only` (all when it is empty; the
    others are kept as they are in `out_path`), judges each (`judge_case(case, body, scene,
    prob, sol, info, robot)`: its record, why it may not be written, its line), prints its line
    and writes the fixture of those that may be written (`write_fixture`, the robot's
    ROBOT_KEYS and the keys given with it)."""
    robot, more_keys = robot_and_keys
    t_all = time.time()
    previous = {c["name"]: c for c in json.loads(out_path.read_text())["cases"]} if out_path.exists() and only else {}
    done, left_out = {}, []
    for ray in rays(cases, robot):
        if only and not any(c["name"] in only for c in ray):
            done.update({c["name"]: previous[c["name"]] for c in ray if c["name"] in previous})
            continue
        for case, body, scene, prob, sol, info in solve_ray(ray, robot, rng):
            out, why, line = judge_case(case, body, scene, prob, sol, info, robot)
            out["seconds"] = info["seconds"]
            print(line, flush=True)
            if why:
                print(f"  NOT WRITTEN: {'; '.join(why)}")
                left_out.append(case["name"])
            else:
                done[case["name"]] = out
    written = [done[c["name"]] for c in cases if c["name"] in done]
    write_fixture(out_path, generator, doc, robot, more_keys, written, (t_all, left_out))


ROBOT_KEYS = ("l", "m", "k", "r", "b", "c", "ms", "g", "Md", "full", "rear_offset", "front_offset", "cup_diameter",
              "tube_length_min")


def write_fixture(out, generator, doc, robot, more_keys, cases, timing):
    """Writes a fixture of `cases` for `robot` (its ROBOT_KEYS and `more_keys`) to `out`, as
    made by `generator` (whose docstring `doc` describes it), and says so."""
    t_all, left_out = timing
    text = dict(
        generator=generator,
        versions={"python": sys.version.split()[0], "numpy": np.__version__, "scipy": scipy.__version__},
        robot={k: robot[k] for k in ROBOT_KEYS + tuple(more_keys)},
        description=doc.strip().splitlines()[0],
        seconds=sum(c["seconds"] for c in cases),
        cases=cases,
    )
    out.write_text(json.dumps(text, indent=1) + "\n")
    print(f"wrote {out.relative_to(ROOT)}: {len(cases)} cases in {time.time() - t_all:.0f} s"
          + (f"; left out: {', '.join(left_out)}" if left_out else ""))


if __name__ == "__main__":
    main(sys.argv)
