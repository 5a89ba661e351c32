#!/usr/bin/env python3
"""Independent validation references for the leech statics solver.

Writes three JSON fixtures that the Rust tests read:

  crates/leech/tests/data/single_chain.json  one clamped chain (SciPy + MuJoCo)
  crates/leech/tests/data/two_chain.json     two chains welded at the endpoint (SciPy + MuJoCo)
  crates/leech/tests/data/elastica.json      continuous heavy cantilever (SciPy shooting + solve_bvp)

The model is the one in docs/model.md (links with point masses, torsional springs,
absolute link angles phi_j from +x, counter-clockwise positive, y up, gravity (0, -g)).
Everything here is written from the equations, not from the Rust code, so that the
fixtures are a real second implementation:

* SciPy is the reference. Equilibria are minima of the potential V (single chain) or
  constrained minima of V (two chains), found by a SciPy optimizer and then polished by
  Newton's method to a residual below 1e-13, so the stored numbers are accurate to
  (nearly) double precision.
* MuJoCo is the second opinion. It knows nothing about V: it integrates the damped
  dynamics of hinge chains until they stop. Its rest state must agree with SciPy to
  1e-6 (rad, m) or the case is not written.

Run:  python3 validation/references.py     (see validation/README.md)
"""

from __future__ import annotations

import json
import math
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import mujoco
import numpy as np
import scipy
from scipy import integrate, linalg, optimize

ROOT = Path(__file__).resolve().parent.parent
DATA = ROOT / "crates" / "leech" / "tests" / "data"
GENERATOR = "validation/references.py"
VERSIONS = {"scipy": scipy.__version__, "mujoco": mujoco.__version__, "numpy": np.__version__}

# Acceptance thresholds.
NEWTON_TOL = 1e-13  # sup norm of the (scaled) stationarity residual after polishing
AGREE_TOL = 1e-6  # SciPy vs MuJoCo, rad and m
SAME_TOL = 1e-7  # two polished SciPy solutions closer than this are the same equilibrium
MAX_STIFFNESS_RATIO = 1e4  # cap on k_j / k for a very short last element


def e(a):
    """Unit vector along angle a."""
    return np.array([math.cos(a), math.sin(a)])


def nu(a):
    """Right-hand normal of e(a)."""
    return np.array([math.sin(a), -math.cos(a)])


# ----------------------------------------------------------------------------------------
# Discrete chain model (numpy, analytic derivatives)
# ----------------------------------------------------------------------------------------


@dataclass
class Chain:
    """One clamped chain, discretized as in the spec.

    The tube is cut into n = ceil(L / l) elements (at least one), e_j = l except the last,
    e_n = L - (n - 1) l in (0, l]. Every element has exactly one joint, with spring
    k_j = k min(l / e_j, 1e4) (k for whole elements, stiffer for a short last one) and damper
    d_j = d min(l / e_j, 1e4). "paper": link j is element j, joint at its start, mass m e_j / l at
    its tip. "midpoint": a rigid root piece of length e_1 / 2 along the clamp, joint j at the middle
    of element j, link j from joint j to joint j + 1 (length (e_j + e_{j+1}) / 2), the last link
    from joint n to the tube tip (e_n / 2); each link carries m (its length) / l at its centre.

    All the gravity potential is linear in sin(phi_j): V_g = g * sum_j lever_j sin(phi_j) + const,
    where lever_j is (length of link j) * (mass carried beyond the start of link j, with the
    link's own mass counted at its mass point). That gives V, grad V and the Hessian in closed
    form without building positions.
    """

    disc: str
    l: float  # element length
    m: float  # element mass
    k: float  # joint stiffness
    L: float  # tube length
    phi0: float  # clamp angle
    base: np.ndarray  # clamp position p0
    tip_mass: float = 0.0
    elements: np.ndarray = field(init=False)  # element lengths e_j
    stiff: np.ndarray = field(init=False)  # joint springs k_j
    lengths: np.ndarray = field(init=False)  # link lengths
    masses: np.ndarray = field(init=False)
    frac: float = field(init=False)  # mass point as a fraction of the link length
    start: np.ndarray = field(init=False)  # start of link 1
    lever: np.ndarray = field(init=False)

    def __post_init__(self):
        l, L = self.l, self.L
        n = max(1, math.ceil(L / l - 1e-9))
        last = L - (n - 1) * l
        assert 0 < last <= l * (1 + 1e-12), (self.disc, L, l, n, last)
        self.elements = np.array([l] * (n - 1) + [last])
        ratio = np.minimum(l / self.elements, MAX_STIFFNESS_RATIO)
        self.stiff = self.k * ratio
        if self.disc == "paper":
            self.lengths = self.elements.copy()  # link j is element j
            self.frac = 1.0  # mass at the tip of each link
            self.start = np.array(self.base, float)
        elif self.disc == "midpoint":
            # joint j at the middle of element j: links run joint to joint, the last to the tip
            self.lengths = 0.5 * (self.elements + np.concatenate([self.elements[1:], [0.0]]))
            self.frac = 0.5  # mass at the centre of each link
            # a massless rigid piece of length e_1 / 2 leaves the clamp along phi0
            self.start = np.array(self.base, float) + 0.5 * self.elements[0] * e(self.phi0)
        else:
            raise ValueError(self.disc)
        self.masses = self.m * self.lengths / l
        beyond = np.concatenate([np.cumsum(self.masses[::-1])[::-1][1:], [0.0]])  # sum_{j>i} M_j
        self.lever = self.lengths * (beyond + self.tip_mass) + self.frac * self.lengths * self.masses

    @property
    def n(self):
        return len(self.lengths)

    @property
    def damp_ratio(self):
        """Joint dampers relative to the nominal one: d_j / d = k_j / k."""
        return self.stiff / self.k

    def rel(self, phi):
        """Joint angles phi_j - phi_{j-1} (phi_0 = clamp)."""
        return np.diff(np.concatenate([[self.phi0], phi]))

    def potential(self, phi, g):
        d = self.rel(phi)
        const = g * (self.masses.sum() + self.tip_mass) * self.start[1]
        return 0.5 * np.dot(self.stiff, d * d) + g * np.dot(self.lever, np.sin(phi)) + const

    def grad(self, phi, g):
        d = self.rel(phi)
        kd = self.stiff * d
        spring = kd - np.concatenate([kd[1:], [0.0]])
        return spring + g * self.lever * np.cos(phi)

    def hess(self, phi, g):
        n = self.n
        h = np.zeros((n, n))
        i = np.arange(n)
        kn = np.concatenate([self.stiff[1:], [0.0]])  # the last joint has a spring only on one side
        h[i, i] = self.stiff + kn
        h[i[:-1], i[:-1] + 1] = -self.stiff[1:]
        h[i[:-1] + 1, i[:-1]] = -self.stiff[1:]
        h[i, i] += -g * self.lever * np.sin(phi)
        return h

    def tip(self, phi):
        return self.start + np.array([np.dot(self.lengths, np.cos(phi)), np.dot(self.lengths, np.sin(phi))])

    def tip_jac(self, phi):
        return np.vstack([-self.lengths * np.sin(phi), self.lengths * np.cos(phi)])

    def straight(self):
        return np.full(self.n, self.phi0)

    def arc(self, theta):
        """Constant curvature: the angle grows linearly with arc length, total bend theta."""
        s_end = np.cumsum(self.lengths) + (self.start_offset())
        s_mid = s_end - 0.5 * self.lengths
        return self.phi0 + theta * s_mid / self.L

    def start_offset(self):
        return 0.5 * self.elements[0] if self.disc == "midpoint" else 0.0


def newton_polish(grad, hess, x, scale, tol=NEWTON_TOL, maxit=50):
    """Newton on grad = 0 until |grad|_inf / scale < tol. Returns x and the final residual."""
    r = np.max(np.abs(grad(x))) / scale
    for _ in range(maxit):
        if r < tol:
            break
        x = x - linalg.solve(hess(x), grad(x), assume_a="sym")
        r = np.max(np.abs(grad(x))) / scale
    return x, r


def check_derivatives(fun, grad, x, h=1e-6):
    """Central finite differences: guards against a wrong analytic gradient/Hessian."""
    g = np.array([(fun(x + h * ei) - fun(x - h * ei)) / (2 * h) for ei in np.eye(len(x))])
    gx = grad(x)
    return np.max(np.abs(g - gx)) / max(1.0, np.max(np.abs(gx)))


# ----------------------------------------------------------------------------------------
# Single chain: SciPy reference
# ----------------------------------------------------------------------------------------


def solve_single(ch: Chain, g: float):
    """Stable equilibrium on the loading branch: from the straight (unloaded) tube, gravity is
    raised in ten steps; each step is a BFGS minimization of V warm started from the last one,
    then Newton-polished. Returns angles, |grad V|_inf / k and the smallest Hessian eigenvalue."""
    x = ch.straight()
    for s in np.linspace(0.1, 1.0, 10):
        x = optimize.minimize(lambda p: ch.potential(p, s * g), x, jac=lambda p: ch.grad(p, s * g),
                              method="BFGS", options={"gtol": 1e-10 * ch.k, "maxiter": 20000}).x
        x, res = newton_polish(lambda p: ch.grad(p, s * g), lambda p: ch.hess(p, s * g), x, ch.k)
    return x, res, float(np.linalg.eigvalsh(ch.hess(x, g))[0])


def distinct_minima_single(ch: Chain, g: float, ref, rng):
    """Other starting guesses (straight, hanging, curled, random): list stable minima not equal to ref."""
    n = ch.n
    starts = [ch.straight(), np.full(n, -math.pi / 2), np.full(n, 3 * math.pi / 2),
              ch.phi0 + np.linspace(0, -math.pi, n), ch.phi0 + np.linspace(0, math.pi, n)]
    starts += [ref + rng.normal(0, 0.5, n) for _ in range(4)]
    others = []
    for x0 in starts:
        r = optimize.minimize(lambda p: ch.potential(p, g), x0, jac=lambda p: ch.grad(p, g),
                              method="BFGS", options={"gtol": 1e-10 * ch.k, "maxiter": 20000})
        try:
            x, res = newton_polish(lambda p: ch.grad(p, g), lambda p: ch.hess(p, g), r.x, ch.k)
        except linalg.LinAlgError:
            continue
        if res > 1e-9 or np.linalg.eigvalsh(ch.hess(x, g))[0] <= 0:
            continue
        if np.max(np.abs(x - ref)) > SAME_TOL and all(np.max(np.abs(x - o)) > SAME_TOL for o in others):
            others.append(x)
    return others


# ----------------------------------------------------------------------------------------
# MuJoCo second opinion (shared by one and two chains)
# ----------------------------------------------------------------------------------------
#
# The plane of the model is MuJoCo's x-z plane (model y -> MuJoCo z). Hinges turn about -Y, so a
# positive joint angle turns counter-clockwise in the model plane (local x -> e(phi), local
# z -> e'(phi), the left normal). Body j's frame sits at the start of link j with x along it.
# MuJoCo hinges measure the RELATIVE angle of a body to its parent, from the orientation the body
# has at qpos = 0. We build qpos = 0 as a given initial shape phi_init (bodies rotated by
# delta_j = phi_init_j - phi_init_{j-1}) and put the spring's rest at springref = -delta_j, so the
# spring is relaxed when the tube is straight along the clamp, as the model wants. The absolute
# angle is then phi_j = phi_init_j + sum_{i<=j} q_i.


def quat_about_minus_y(a):
    return (math.cos(a / 2), 0.0, -math.sin(a / 2), 0.0)


def fmt(*v):
    return " ".join(repr(float(x)) for x in v)


def chain_xml(prefix: str, ch: Chain, phi_init, damping: float, tip_extra: float) -> str:
    """Nested bodies for one chain. Point masses are small massive spheres (contacts are off)."""
    # Sphere radius 0.1 l: the mass acts as a point for statics (inertia never enters statics).
    # Much smaller spheres (1e-2 l) leave the end links with almost no rotational inertia; the soft
    # weld then leaks badly (its violation grows with the inverse inertia) and the midpoint
    # two-chain case oscillated instead of settling.
    r = 0.1 * ch.l
    xml, prev = [], ch.phi0
    for j in range(ch.n):
        delta = float(phi_init[j] - prev)
        if j == 0:  # first body: placed in the world, oriented absolutely
            pos = (ch.start[0], 0.0, ch.start[1])
            quat = quat_about_minus_y(float(phi_init[0]))
        else:
            pos = (ch.lengths[j - 1], 0.0, 0.0)
            quat = quat_about_minus_y(delta)
        xml.append(f'<body name="{prefix}{j + 1}" pos="{fmt(*pos)}" quat="{fmt(*quat)}">')
        xml.append(f'<joint name="{prefix}j{j + 1}" type="hinge" axis="0 -1 0" stiffness="{fmt(ch.stiff[j])}" '
                   f'springref="{fmt(-delta)}" damping="{fmt(damping * ch.damp_ratio[j])}"/>')
        xml.append(f'<geom type="sphere" size="{fmt(r)}" pos="{fmt(ch.frac * ch.lengths[j], 0, 0)}" '
                   f'mass="{fmt(ch.masses[j])}"/>')
        if j == ch.n - 1 and tip_extra > 0:
            xml.append(f'<geom type="sphere" size="{fmt(r)}" pos="{fmt(ch.lengths[j], 0, 0)}" '
                       f'mass="{fmt(tip_extra)}"/>')
        prev = phi_init[j]
    xml.append("</body>" * ch.n)
    return "\n".join(xml)


def mujoco_model(chains, inits, dampings, g, dt, weld=None):
    bodies = "\n".join(chain_xml(p, ch, ini, d, ch.tip_mass) for (p, ch), ini, d in zip(chains, inits, dampings))
    eq = ""
    if weld is not None:
        body1, body2, relpos = weld
        # Weld the last bodies: body2's frame relative to body1's frame is a pure offset
        # (parallel links). MuJoCo constraints are soft; solref/solimp make this one as stiff as
        # MuJoCo allows (timeconst = 2 dt, impedance 0.9999). At rest the violation is still about
        # (1-d)/d * timeconst^2 * (constraint-space acceleration): ~1e-8 at dt = 1e-5 here.
        eq = (f'<equality><weld body1="{body1}" body2="{body2}" relpose="{fmt(*relpos, 1, 0, 0, 0)}" '
              f'solref="{fmt(2 * dt)} 1" solimp="0.9999 0.9999 0.001 0.5 2"/></equality>')
    xml = f"""<mujoco model="leech-check">
  <compiler angle="radian"/>
  <option timestep="{fmt(dt)}" gravity="0 0 {fmt(-g)}" integrator="implicitfast"
          solver="Newton" iterations="200" tolerance="1e-15" ls_tolerance="1e-12">
    <flag contact="disable"/>
  </option>
  <worldbody>
{bodies}
  </worldbody>
  {eq}
</mujoco>"""
    return mujoco.MjModel.from_xml_string(xml)


def linear_modes(M, K, D):
    """Eigenvalues of M x'' + D x' + K x = 0 (first-order form)."""
    n = len(M)
    Mi = np.linalg.inv(M)
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-Mi @ K, -Mi @ D]])
    return np.linalg.eigvals(A)


def choose_damping(M, K, Dhat, Z=None):
    """Pick the joint damping scale d (damping matrix d * Dhat) for fast settling.

    The target is ~0.3 of critical damping in the lowest mode (modal estimate
    zeta_1 = d v1'Dhat v1 / (2 omega_1 v1'M v1)). Joint dampers act on RELATIVE rates, so stiff
    high modes get much more damping than the lowest one; if that makes some overdamped mode the
    slowest to decay, a smaller d is taken. Returns d, zeta_1, omega_max and the slowest decay
    rate (1/s) of the linearized system at the equilibrium.
    """
    if Z is not None:  # constrained: work on the null space of the constraint Jacobian
        M, K, Dhat = Z.T @ M @ Z, Z.T @ K @ Z, Z.T @ Dhat @ Z
    w2, V = linalg.eigh(K, M)
    assert w2[0] > 0, "equilibrium not stable"
    v1 = V[:, 0]
    omega1 = math.sqrt(w2[0])
    unit = (v1 @ Dhat @ v1) / (2 * omega1 * (v1 @ M @ v1))  # zeta_1 per unit d
    d0 = 0.3 / unit
    ds = d0 * np.logspace(-2, 0, 41)
    rates = np.array([-np.max(linear_modes(M, K, d * Dhat).real) for d in ds])
    # the largest d (closest to the 0.3 target) that settles within 10 % of the fastest choice
    i = np.nonzero(rates >= 0.9 * rates.max())[0][-1]
    return ds[i], ds[i] * unit, math.sqrt(w2[-1]), rates[i]


def run_to_rest(model, data, rate, settle=1e-12, max_time=None):
    """Integrate until the shape stops changing.

    Chunks last 1/rate (the slowest linear decay time), so the change over one chunk is about
    the remaining distance to rest; stop once it is below `settle` (rad). Returns simulated
    time, the last max |qvel| and the wall time.
    """
    assert not model.opt.enableflags & mujoco.mjtEnableBit.mjENBL_SLEEP  # sleeping would freeze it early
    chunk = max(1, int(round(1.0 / rate / model.opt.timestep)))
    if max_time is None:
        max_time = min(60.0, 60.0 / rate)  # e^-60: anything still moving then is not settling
    t0 = time.time()
    while True:
        q = data.qpos.copy()
        mujoco.mj_step(model, data, nstep=chunk)
        if not np.all(np.isfinite(data.qpos)):
            break  # diverged: the caller sees the disagreement and retries with a smaller step
        if np.max(np.abs(data.qpos - q)) < settle or data.time > max_time:
            break
    mujoco.mj_forward(model, data)  # make positions/frames consistent with the final qpos
    return data.time, float(np.max(np.abs(data.qvel))), time.time() - t0


# ----------------------------------------------------------------------------------------
# Single chain cases
# ----------------------------------------------------------------------------------------

G0 = 9.81


def single_case(name, disc, l, m, L, phi0_deg, Pi, tip_mass=0.0, g=G0):
    k = Pi * m * g * l  # shape parameter Pi = k / (m g l)
    return dict(name=name, discretization=disc, element_length_m=l, element_mass_kg=m,
                joint_stiffness_nm_per_rad=k, tube_length_m=L, base_angle_deg=phi0_deg,
                tip_mass_kg=tip_mass, gravity_m_per_s2=g, shape_parameter=k / (m * g * l))


SINGLE_CASES = [
    single_case("paper_pi1_n5_flat", "paper", 0.01, 0.001, 0.05, 0.0, 1.0),
    single_case("paper_pi10_L0.1234_30deg", "paper", 0.01, 0.001, 0.1234, 30.0, 10.0),
    single_case("paper_pi50_n20_45deg_tip", "paper", 0.01, 0.001, 0.20, 45.0, 50.0, tip_mass=0.005),
    single_case("paper_pi200_n30_flat", "paper", 0.01, 0.001, 0.30, 0.0, 200.0),
    single_case("paper_pi2000_n30_135deg_payload", "paper", 0.01, 0.001, 0.30, 135.0, 2000.0, tip_mass=0.021),
    single_case("paper_pi500_l0.02_n15_60deg_tip", "paper", 0.02, 0.003, 0.30, 60.0, 500.0, tip_mass=0.002),
    single_case("paper_pi3_n10_135deg", "paper", 0.01, 0.001, 0.10, 135.0, 3.0),
    single_case("paper_pi20_n12_100deg_moon", "paper", 0.01, 0.001, 0.12, 100.0, 20.0, g=1.62),
    single_case("midpoint_pi5_L0.1234_flat", "midpoint", 0.01, 0.001, 0.1234, 0.0, 5.0),
    single_case("midpoint_pi1000_n25_135deg_tip", "midpoint", 0.01, 0.001, 0.25, 135.0, 1000.0, tip_mass=0.01),
    single_case("midpoint_pi100_L0.0777_75deg", "midpoint", 0.01, 0.001, 0.0777, 75.0, 100.0),
]


def run_single(rng):
    kept, table = [], []
    for c in SINGLE_CASES:
        phi0 = math.radians(c["base_angle_deg"])
        g = c["gravity_m_per_s2"]
        ch = Chain(c["discretization"], c["element_length_m"], c["element_mass_kg"],
                   c["joint_stiffness_nm_per_rad"], c["tube_length_m"], phi0, np.zeros(2), c["tip_mass_kg"])
        # guard the analytic derivatives
        xt = ch.straight() + rng.normal(0, 0.3, ch.n)
        assert check_derivatives(lambda p: ch.potential(p, g), lambda p: ch.grad(p, g), xt) < 1e-6
        assert check_derivatives(lambda p: ch.grad(p, g) @ np.ones(ch.n), lambda p: ch.hess(p, g) @ np.ones(ch.n), xt) < 1e-6
        phi, res, lam_min = solve_single(ch, g)
        others = distinct_minima_single(ch, g, phi, rng)

        # MuJoCo: start straight along the clamp (the unloaded state), gravity on, run to rest.
        probe = mujoco_model([("c", ch)], [ch.straight()], [0.0], g, 5e-5)
        data = mujoco.MjData(probe)
        data.qpos[:] = ch.rel(phi)  # relative angles: evaluate the mass matrix at the equilibrium
        mujoco.mj_forward(probe, data)
        M = np.zeros((probe.nv, probe.nv))
        mujoco.mj_fullM(probe, data, M)
        S = np.tril(np.ones((ch.n, ch.n)))  # dphi/dq
        K = S.T @ ch.hess(phi, g) @ S
        d, zeta1, wmax, rate = choose_damping(M, K, np.diag(ch.damp_ratio))
        # Springs are explicit in MuJoCo: keep omega_max dt well below 2. If the run does not agree,
        # try again with smaller steps (never needed for the cases below, kept as the fallback).
        dt = min(5e-5, 0.5 / wmax)
        for attempt in range(3):
            model = mujoco_model([("c", ch)], [ch.straight()], [d], g, dt)
            data = mujoco.MjData(model)
            t_sim, vmax, wall = run_to_rest(model, data, rate)
            phi_mj = ch.straight() + np.cumsum(data.qpos)
            diff = float(np.max(np.abs(phi_mj - phi)))
            if diff < AGREE_TOL:
                break
            dt /= 4
        if np.all(np.isfinite(data.qpos)):
            # cross-check the angle bookkeeping against MuJoCo's own body frames
            xm = data.xmat[model.body(f"c{ch.n}").id].reshape(3, 3)[:, 0]  # local x = e(phi_n) in (x, z)
            assert abs(np.angle(complex(xm[0], xm[2]) * complex(math.cos(phi_mj[-1]), -math.sin(phi_mj[-1])))) < 1e-9
        # Heavy, floppy chains also have a stable shape wrapped round the far side of the clamp
        # (higher energy, not reachable by loading from straight). Keep a case only if the
        # reference is the lowest minimum found from all starts.
        v_ref = ch.potential(phi, g)
        lowest = all(v_ref < ch.potential(o, g) - 1e-9 * ch.k for o in others)
        ok = diff < AGREE_TOL and res < NEWTON_TOL and lam_min > 0 and lowest
        row = dict(c)
        row.update(angles_rad=[float(a) for a in phi], tip_m=[float(v) for v in ch.tip(phi)],
                   mujoco_max_abs_diff_rad=diff)
        table.append((c["name"], ch.n, c["shape_parameter"], res, lam_min, f"{len(others)}{'' if lowest else '!'}",
                      zeta1, dt, t_sim, wall, diff, ok))
        if ok:
            kept.append(row)
    print("\nsingle chain (SciPy reference vs MuJoCo run to rest)")
    print(f"{'case':38s} {'n':>3s} {'Pi':>7s} {'|gradV|/k':>9s} {'minEigH':>9s} {'other':>5s} "
          f"{'zeta1':>5s} {'dt':>7s} {'t_sim':>6s} {'wall':>5s} {'MJ diff':>9s} kept")
    for r in table:
        print(f"{r[0]:38s} {r[1]:3d} {r[2]:7.1f} {r[3]:9.1e} {r[4]:9.2e} {r[5]:>5s} {r[6]:5.2f} {r[7]:7.1e} "
              f"{r[8]:6.1f} {r[9]:5.1f} {r[10]:9.2e} {'yes' if r[11] else 'NO'}")
    return kept


# ----------------------------------------------------------------------------------------
# Two chains welded at the endpoint: SciPy constrained reference
# ----------------------------------------------------------------------------------------


@dataclass
class TwoChain:
    """Chain A (one tube: k, m) from p0 = 0 and chain B (two tubes lumped: 2k, 2m) from b nu(phi0),
    payload at B's tip; the endpoint plate is a weld: pB - pA - c nu(phiA_n) = 0, phiA_n = phiB_n."""

    A: Chain
    B: Chain
    c: float

    @classmethod
    def make(cls, disc, l, m, k, b, c, ms, phi0, LA, LB):
        A = Chain(disc, l, m, k, LA, phi0, np.zeros(2))
        B = Chain(disc, l, 2 * m, 2 * k, LB, phi0, b * nu(phi0), tip_mass=ms)
        return cls(A, B, c)

    @property
    def nA(self):
        return self.A.n

    def split(self, q):
        return q[: self.nA], q[self.nA:]

    def potential(self, q, g):
        a, b = self.split(q)
        return self.A.potential(a, g) + self.B.potential(b, g)

    def grad(self, q, g):
        a, b = self.split(q)
        return np.concatenate([self.A.grad(a, g), self.B.grad(b, g)])

    def hess(self, q, g):
        a, b = self.split(q)
        return linalg.block_diag(self.A.hess(a, g), self.B.hess(b, g))

    def cons(self, q):
        a, b = self.split(q)
        d = self.B.tip(b) - self.A.tip(a) - self.c * nu(a[-1])
        return np.array([d[0], d[1], a[-1] - b[-1]])

    def cons_jac(self, q):
        a, b = self.split(q)
        J = np.zeros((3, len(q)))
        J[:2, : self.nA] = -self.A.tip_jac(a)
        J[:2, self.nA:] = self.B.tip_jac(b)
        J[:2, self.nA - 1] += -self.c * e(a[-1])  # d nu / da = e
        J[2, self.nA - 1] = 1.0
        J[2, -1] = -1.0
        return J

    def cons_hess(self, q, lam):
        """sum_r lam_r Hess(C_r). The tips are sums of l_i e(phi_i), so each Hessian is diagonal."""
        a, b = self.split(q)
        la = lam[:2]
        A, B = self.A, self.B
        h = np.concatenate([A.lengths * (la[0] * np.cos(a) + la[1] * np.sin(a)),   # -d2 pA = +l e(a)
                            -B.lengths * (la[0] * np.cos(b) + la[1] * np.sin(b))])  # +d2 pB = -l e(b)
        h[self.nA - 1] += self.c * (la @ nu(a[-1]))  # -c d2 nu / da2 = +c nu
        return np.diag(h)

    def kkt_residual(self, q, lam, g):
        """Stationarity scaled by k (-> rad), weld position by l (-> rad-like), parallel in rad."""
        r1 = (self.grad(q, g) - self.cons_jac(q).T @ lam) / self.A.k
        c = self.cons(q)
        return np.concatenate([r1, c[:2] / self.A.l, c[2:]])

    def kkt_polish(self, q, g, tol=NEWTON_TOL, maxit=50):
        """Newton on [grad V - J^T lam; C] = 0 with the constraint Hessians in the Lagrangian."""
        J = self.cons_jac(q)
        lam = np.linalg.lstsq(J.T, self.grad(q, g), rcond=None)[0]
        n = len(q)
        for _ in range(maxit):
            r = self.kkt_residual(q, lam, g)
            if np.max(np.abs(r)) < tol:
                break
            J = self.cons_jac(q)
            H = self.hess(q, g) - self.cons_hess(q, lam)
            K = np.block([[H, -J.T], [J, np.zeros((3, 3))]])
            F = np.concatenate([self.grad(q, g) - J.T @ lam, self.cons(q)])
            step = np.linalg.solve(K, -F)
            q, lam = q + step[:n], lam + step[n:]
        r = self.kkt_residual(q, lam, g)
        return q, lam, float(np.max(np.abs(r)))

    def reduced_min_eig(self, q, lam, g):
        """Smallest eigenvalue of Z^T H_L Z, Z an orthonormal basis of null(J) (Euclidean in angles)."""
        Z = linalg.null_space(self.cons_jac(q))
        HL = self.hess(q, g) - self.cons_hess(q, lam)
        return float(np.linalg.eigvalsh(Z.T @ HL @ Z)[0])

    def arc(self):
        """Constant-curvature guess: both chains bend by theta = (LB - LA) / ((b + c) / 2)."""
        b = np.linalg.norm(self.B.base - self.A.base)
        theta = (self.B.L - self.A.L) / (0.5 * (b + self.c))
        return np.concatenate([self.A.arc(theta), self.B.arc(theta)])

    def minimize(self, q0, g):
        """SciPy trust-constr on V with the three equality constraints, then KKT Newton polish."""
        con = optimize.NonlinearConstraint(self.cons, 0.0, 0.0, jac=self.cons_jac,
                                           hess=lambda q, v: self.cons_hess(q, v))
        r = optimize.minimize(lambda q: self.potential(q, g), q0, jac=lambda q: self.grad(q, g),
                              hess=lambda q: self.hess(q, g), method="trust-constr", constraints=[con],
                              options={"gtol": 1e-11 * self.A.k, "xtol": 1e-14, "maxiter": 5000})
        return self.kkt_polish(r.x, g)


def solve_two(tc: TwoChain, g: float, steps=20):
    """The branch of the spec: g = 0 from the arc guess, then gravity raised in steps."""
    q, lam, res = tc.minimize(tc.arc(), 0.0)
    q_unloaded = q.copy()
    min_eig_path = tc.reduced_min_eig(q, lam, 0.0)
    for s in np.linspace(0, 1, steps + 1)[1:]:
        q, lam, res = tc.minimize(q, s * g)
        min_eig_path = min(min_eig_path, tc.reduced_min_eig(q, lam, s * g))
    return q_unloaded, q, lam, res, min_eig_path


def other_minima_two(tc: TwoChain, g: float, ref, rng):
    """Direct solves at full gravity from other guesses: arc, straight, bowed, perturbed."""
    nA, nB = tc.A.n, tc.B.n
    sA = np.linspace(0, 1, nA)
    sB = np.linspace(0, 1, nB)
    arc = tc.arc()
    starts = [arc, np.concatenate([tc.A.straight(), tc.B.straight()]),
              arc + np.concatenate([0.6 * np.sin(np.pi * sA), np.zeros(nB)]),   # chain A bowing out
              arc - np.concatenate([0.6 * np.sin(np.pi * sA), np.zeros(nB)]),
              arc + np.concatenate([np.zeros(nA), 0.6 * np.sin(np.pi * sB)])]
    starts += [ref + rng.normal(0, 0.3, nA + nB) for _ in range(3)]
    others = []
    for q0 in starts:
        try:
            q, lam, res = tc.minimize(q0, g)
        except np.linalg.LinAlgError:
            continue
        if res > 1e-9 or tc.reduced_min_eig(q, lam, g) <= 0:
            continue
        if np.max(np.abs(q - ref)) > SAME_TOL and all(np.max(np.abs(q - o)) > SAME_TOL for o in others):
            others.append(q)
    return others


def two_case(name, disc, k, LA, LB, b, c, ms, phi0_deg, l=0.01, m=0.001, g=G0):
    return dict(name=name, discretization=disc, element_length_m=l, element_mass_kg=m,
                joint_stiffness_nm_per_rad=k, base_spacing_m=b, tip_spacing_m=c, payload_kg=ms,
                base_angle_deg=phi0_deg, gravity_m_per_s2=g, lengths_m=[LA, LB])


TWO_CASES = [
    two_case("equal_n20_bc_flat_pi5097", "paper", 0.5, 0.20, 0.20, 0.015, 0.015, 0.021, 0.0),
    two_case("n15_n20_45deg_pi2039", "paper", 0.2, 0.15, 0.20, 0.017, 0.012, 0.021, 45.0),
    two_case("n25_n18_90deg_pi1019", "paper", 0.1, 0.25, 0.18, 0.017, 0.012, 0.021, 90.0),
    two_case("n10_n13_flat_pi510", "paper", 0.05, 0.10, 0.13, 0.015, 0.015, 0.021, 0.0),
    two_case("n30_n24_45deg_nopayload_pi3058", "paper", 0.3, 0.30, 0.24, 0.015, 0.015, 0.0, 45.0),
    two_case("equal_n8_sshape_flat_pi510", "paper", 0.05, 0.08, 0.08, 0.017, 0.012, 0.021, 0.0),
    two_case("midpoint_L0.12_L0.1234_90deg_pi1529", "midpoint", 0.15, 0.12, 0.1234, 0.017, 0.012, 0.021, 90.0),
    two_case("n8_n10_flat_pi51", "paper", 0.005, 0.08, 0.10, 0.015, 0.015, 0.021, 0.0),
]


def run_two(rng):
    kept, table = [], []
    for c in TWO_CASES:
        g = c["gravity_m_per_s2"]
        phi0 = math.radians(c["base_angle_deg"])
        LA, LB = c["lengths_m"]
        tc = TwoChain.make(c["discretization"], c["element_length_m"], c["element_mass_kg"],
                           c["joint_stiffness_nm_per_rad"], c["base_spacing_m"], c["tip_spacing_m"],
                           c["payload_kg"], phi0, LA, LB)
        nA, nB = tc.A.n, tc.B.n
        # guard the analytic constraint Jacobian and Hessian
        qt = tc.arc() + rng.normal(0, 0.2, nA + nB)
        lt = rng.normal(0, 1, 3)
        assert check_derivatives(lambda q: tc.cons(q) @ lt, lambda q: tc.cons_jac(q).T @ lt, qt) < 1e-6
        assert check_derivatives(lambda q: tc.cons_jac(q).T @ lt @ np.ones(nA + nB),
                                 lambda q: tc.cons_hess(q, lt) @ np.ones(nA + nB), qt) < 1e-6

        q_unloaded, q, lam, res, eig_path = solve_two(tc, g)
        eig = tc.reduced_min_eig(q, lam, g)
        others = other_minima_two(tc, g, q, rng)
        others0 = other_minima_two(tc, 0.0, q_unloaded, rng)  # is the unloaded shape unique too?

        # MuJoCo: start from the unloaded (g = 0) equilibrium, which satisfies the weld, with gravity on.
        a0, b0 = tc.split(q_unloaded)
        relpos = (tc.A.lengths[-1] - tc.B.lengths[-1], 0.0, -tc.c)  # B's last frame in A's last frame
        weld = ("a%d" % nA, "b%d" % nB, relpos)
        a, b = tc.split(q)
        probe = mujoco_model([("a", tc.A), ("b", tc.B)], [a0, b0], [0.0, 0.0], g, 5e-5, weld)
        data = mujoco.MjData(probe)
        mujoco.mj_forward(probe, data)
        weld_err0 = float(np.max(np.abs(data.efc_pos)))  # checks relpose: the start must satisfy it
        assert weld_err0 < 1e-10, weld_err0
        qm_eq = np.concatenate([tc.A.rel(a) - tc.A.rel(a0), tc.B.rel(b) - tc.B.rel(b0)])
        data.qpos[:] = qm_eq
        mujoco.mj_forward(probe, data)
        M = np.zeros((probe.nv, probe.nv))
        mujoco.mj_fullM(probe, data, M)
        S = linalg.block_diag(np.tril(np.ones((nA, nA))), np.tril(np.ones((nB, nB))))  # dphi/dq
        HL = tc.hess(q, g) - tc.cons_hess(q, lam)
        Z = linalg.null_space(tc.cons_jac(q) @ S)
        # dampers d_j and 2 d_j, like k_j and 2 k_j
        Dhat = np.diag(np.concatenate([tc.A.damp_ratio, 2 * tc.B.damp_ratio]))
        d, zeta1, wmax, rate = choose_damping(M, S.T @ HL @ S, Dhat, Z)
        # The weld is a soft constraint: at rest it is violated by about
        # (1 - dmax) * (2 dt)^2 * (constraint-space acceleration), i.e. ~1e-7 at dt = 5e-5 here, so a
        # 1e-5 step is used (~4e-9). With tiny end links and joint dampers stiff relative to their
        # inertia, larger steps can also go unstable; a run that does not agree is retried smaller.
        dt = min(1e-5, 0.5 / wmax)
        tipA_ref = tc.A.tip(a)
        for attempt in range(3):
            model = mujoco_model([("a", tc.A), ("b", tc.B)], [a0, b0], [d, 2 * d], g, dt, weld)
            data = mujoco.MjData(model)
            t_sim, vmax, wall = run_to_rest(model, data, rate)
            a_mj = a0 + np.cumsum(data.qpos[:nA])
            b_mj = b0 + np.cumsum(data.qpos[nA:])
            last = model.body("a%d" % nA).id
            R = data.xmat[last].reshape(3, 3)
            tipA = data.xpos[last] + tc.A.lengths[-1] * R[:, 0]  # tip of A's last link, MuJoCo (x, z)
            tip_mj = np.array([tipA[0], tipA[2]])
            weld_err = float(np.max(np.abs(data.efc_pos)))
            diff = float(max(np.max(np.abs(a_mj - a)), np.max(np.abs(b_mj - b)), np.max(np.abs(tip_mj - tipA_ref))))
            if diff < AGREE_TOL:
                break
            dt /= 4
        ok = (diff < AGREE_TOL and res < NEWTON_TOL and eig > 0 and eig_path > 0 and not others and not others0)
        row = dict(c)
        row.update(angles_a_rad=[float(x) for x in a], angles_b_rad=[float(x) for x in b],
                   endpoint_m=[float(x) for x in tipA_ref], endpoint_angle_rad=float(a[-1]),
                   min_reduced_eigenvalue=eig, mujoco_max_abs_diff=diff)
        table.append((c["name"], nA, nB, c["joint_stiffness_nm_per_rad"] / (c["element_mass_kg"] * g * c["element_length_m"]),
                      res, eig, eig_path, len(others), len(others0), zeta1, dt, t_sim, wall, weld_err, diff, ok))
        if ok:
            kept.append(row)
    print("\ntwo chains (SciPy trust-constr + KKT Newton vs MuJoCo weld run to rest)")
    print(f"{'case':38s} {'nA':>3s} {'nB':>3s} {'Pi':>7s} {'KKT res':>8s} {'minEigZ':>9s} {'path min':>9s} "
          f"{'oth':>3s} {'oth0':>4s} {'zeta1':>5s} {'dt':>7s} {'t_sim':>6s} {'wall':>5s} {'weld err':>8s} {'MJ diff':>9s} kept")
    for r in table:
        print(f"{r[0]:38s} {r[1]:3d} {r[2]:3d} {r[3]:7.1f} {r[4]:8.1e} {r[5]:9.2e} {r[6]:9.2e} {r[7]:3d} {r[8]:4d} "
              f"{r[9]:5.2f} {r[10]:7.1e} {r[11]:6.1f} {r[12]:5.1f} {r[13]:8.1e} {r[14]:9.2e} {'yes' if r[15] else 'NO'}")
    return kept


# ----------------------------------------------------------------------------------------
# Continuous heavy cantilever (elastica)
# ----------------------------------------------------------------------------------------
# EI theta'' = (w (L - s) + P) cos theta, theta(0) = phi0, theta'(L) = 0. With t = s / L:
#   theta_tt = beta (1 - t + p) cos theta,  beta = w L^3 / EI,  p = P / (w L),
#   x_t = cos theta, y_t = sin theta  (positions in units of L).


def elastica_rhs(beta, p):
    def f(t, y):
        th, dth = y[0], y[1]
        return [dth, beta * (1 - t + p) * math.cos(th), math.cos(th), math.sin(th)]
    return f


def shoot(beta, p, phi0, u, rtol=1e-13):
    """Integrate from t = 0 with theta'(0) = u; returns the state [theta, theta', x, y] at t = 1."""
    sol = integrate.solve_ivp(elastica_rhs(beta, p), (0.0, 1.0), [phi0, u, 0.0, 0.0],
                              method="DOP853", rtol=rtol, atol=rtol)
    return sol.y[:, -1]


def elastica_roots(beta, p, phi0, rtol=1e-13):
    """All shooting roots theta'(1; u) = 0 on a bracket that must contain them:
    |theta'(0)| = |int_0^1 beta (1 - t + p) cos theta dt| <= beta (1/2 + p)."""
    bound = beta * (0.5 + p) * 1.01 + 1e-3
    us = np.linspace(-bound, bound, 801)
    fs = [shoot(beta, p, phi0, u, 1e-9)[1] for u in us]  # coarse scan only locates sign changes
    roots = []
    for i in range(len(us) - 1):
        if fs[i] == 0 or fs[i] * fs[i + 1] < 0:
            roots.append(optimize.brentq(lambda u: shoot(beta, p, phi0, u, rtol)[1], us[i], us[i + 1],
                                         xtol=1e-15, rtol=4 * np.finfo(float).eps, maxiter=200))
    return roots


def elastica_bvp(beta, p, phi0, u_guess):
    """Independent cross-check by collocation (solve_bvp) from a rough straight-line guess."""
    t = np.linspace(0, 1, 101)
    y0 = np.vstack([phi0 + u_guess * t * (1 - t / 2), u_guess * (1 - t), t * math.cos(phi0), t * math.sin(phi0)])
    f = elastica_rhs(beta, p)
    fun = lambda t, y: np.vstack([y[1], beta * (1 - t + p) * np.cos(y[0]), np.cos(y[0]), np.sin(y[0])])
    bc = lambda ya, yb: np.array([ya[0] - phi0, yb[1], ya[2], ya[3]])
    sol = integrate.solve_bvp(fun, bc, t, y0, tol=1e-10, max_nodes=200000)
    assert sol.success, sol.message
    return sol.y[:, -1], sol.y[1, 0]


ELASTICA_CASES = [(0.5, 0.0, 0.0), (2.0, 0.0, 0.0), (5.0, 0.0, 0.0), (10.0, 0.0, 0.0),
                  (2.65, 0.0, 0.0), (2.0, 45.0, 0.0), (5.0, 0.0, 0.5), (5.0, 45.0, 0.25)]


def run_elastica():
    cases, table = [], []
    for beta, phi0_deg, p in ELASTICA_CASES:
        phi0 = math.radians(phi0_deg)
        roots = elastica_roots(beta, p, phi0)
        assert len(roots) == 1, (beta, phi0_deg, p, roots)  # unique: no branch choice to make
        u = roots[0]
        th, dth, x, y = shoot(beta, p, phi0, u)
        th2, _, x2, y2 = shoot(beta, p, phi0, elastica_roots(beta, p, phi0, rtol=1e-12)[0], rtol=1e-12)
        err_tol = max(abs(x - x2), abs(y - y2), abs(th - th2))  # tolerance 1e-13 vs 1e-12
        yb, ub = elastica_bvp(beta, p, phi0, u)
        err_bvp = max(abs(x - yb[2]), abs(y - yb[3]), abs(th - yb[0]))
        cases.append(dict(beta=beta, base_angle_deg=phi0_deg, tip_load_ratio=p,
                          tip_over_length=[float(x), float(y)], tip_angle_rad=float(th)))
        table.append((beta, phi0_deg, p, u, x, y, th, abs(dth), err_tol, err_bvp))
    print("\nelastica (shooting: DOP853 rtol=atol=1e-13 + brentq; cross-checks: rtol 1e-12 rerun, solve_bvp tol 1e-10)")
    print(f"{'beta':>5s} {'phi0':>5s} {'P/wL':>5s} {'theta_s(0)':>12s} {'x/L':>16s} {'y/L':>16s} {'theta(L)':>16s} "
          f"{'|th_s(L)|':>9s} {'d(rtol)':>8s} {'d(bvp)':>8s}")
    for r in table:
        print(f"{r[0]:5.2f} {r[1]:5.1f} {r[2]:5.2f} {r[3]:12.8f} {r[4]:16.13f} {r[5]:16.13f} {r[6]:16.13f} "
              f"{r[7]:9.1e} {r[8]:8.1e} {r[9]:8.1e}")
    return cases


def convergence_check():
    """Informational: the discrete chain (k = EI/h, m = rho h) tends to the elastica fixture, at first
    order for "paper" and second order for "midpoint". Ties the two sets of conventions together."""
    beta, g = 2.65, G0
    th, _, x, y = shoot(beta, 0.0, 0.0, elastica_roots(beta, 0.0, 0.0)[0])
    print(f"\ndiscrete chain -> elastica, beta = {beta}, phi0 = 0 (tip error / L)")
    for disc in ("paper", "midpoint"):
        errs = []
        for n in (10, 20, 40, 80):
            h = 1.0 / n
            ch = Chain(disc, h, beta * h / g, 1.0 / h, 1.0, 0.0, np.zeros(2))  # L = 1, EI = 1, w = beta
            phi, _, _ = solve_single(ch, g)
            errs.append(float(np.max(np.abs(ch.tip(phi) - [x, y]))))
        print(f"  {disc:8s} n = 10, 20, 40, 80: " + "  ".join(f"{v:.2e}" for v in errs))


# ----------------------------------------------------------------------------------------
# Main
# ----------------------------------------------------------------------------------------


def write(name, cases):
    DATA.mkdir(parents=True, exist_ok=True)
    path = DATA / name
    # json writes floats with repr(), i.e. shortest round-trip full precision
    path.write_text(json.dumps({"generator": GENERATOR, "versions": VERSIONS, "cases": cases}, indent=1) + "\n")
    print(f"wrote {path.relative_to(ROOT)} ({len(cases)} cases)")


def main():
    rng = np.random.default_rng(20240607)
    which = set(sys.argv[1:]) or {"single", "two", "elastica"}
    if "single" in which:
        write("single_chain.json", run_single(rng))
    if "two" in which:
        write("two_chain.json", run_two(rng))
    if "elastica" in which:
        write("elastica.json", run_elastica())
        convergence_check()


if __name__ == "__main__":
    main()
