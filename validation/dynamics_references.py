#!/usr/bin/env python3
"""Dynamics references for the leech simulator: damped motion of the "paper" chain in MuJoCo.

Writes crates/leech/tests/data/dynamics.json. Reuses the model of references.py (element lengths,
springs k_j, masses, clamp, TwoChain weld geometry, and the SciPy g = 0 equilibrium of the body);
only the MuJoCo model is new, because the dynamics need what the statics did not:

* point masses with (next to) no rotational inertia: each body gets an explicit <inertial> at the
  tip of its link, mass m_j (plus the payload on chain B's last link) and diaginertia INERTIA, the
  smallest round value MuJoCo accepts with margin (it rejects < mjMINVAL = 1e-15); the sphere
  geoms are visual only (radius 0.01 l, no mass, no contacts);
* hinge dampers d_j (d for chain A / the single chain, 2 d for chain B) on the relative rates,
  next to the springs k_j: MuJoCo's hinge `damping` and `stiffness`;
* the RK4 integrator (springs, dampers and the soft weld all explicit, fourth order), with the
  largest step of 1e-5, 5e-6, 2e-6, ... s that keeps |lambda|_max dt <= 2, lambda_max the stiffest
  eigenvalue of the linearization at the initial state (the joint dampers against the small link
  inertias make the equations stiff: about 8e4 1/s for the chain, 7e5 1/s for the body).

Checks, all printed, and the case is written only if they pass:

* time step: the run is repeated at half the step (same weld softness); the largest tip difference
  is stored as half_step_difference_m and must be < 1e-7 m;
* point inertia: the run is repeated with a 100x larger body inertia; the change must be < 1e-7 m;
* weld (body): the model's own weld residual (TwoChain.cons on MuJoCo's angles) over every step;
  a rerun with the weld twice as stiff shows its effect on the tip;
* an independent SciPy integration of the exact Lagrangian equations (mass matrix from the point
  masses, exact weld as a holonomic constraint in index-1 form, Radau at rtol = atol = 1e-12) must
  agree with MuJoCo to 1e-6 m along the whole tip trajectory and to 1e-6 rad in the stored angles.

Run:  validation/.venv/bin/python validation/dynamics_references.py     (see validation/README.md)
"""

from __future__ import annotations

import json
import math
import sys
import time
from pathlib import Path

import mujoco
import numpy as np
from scipy import integrate

sys.path.insert(0, str(Path(__file__).resolve().parent))
import references as R  # noqa: E402  (the statics model: Chain, TwoChain, fmt, quat_about_minus_y)

GENERATOR = "validation/dynamics_references.py"
OUT = R.DATA / "dynamics.json"

INERTIA = 1e-14  # kg m^2, each body's own rotational inertia (the Rust model has exactly 0)
DT_CHOICES = (1e-5, 5e-6, 2e-6, 1e-6, 5e-7, 2e-7, 1e-7)  # s, MuJoCo step: the largest one with
RK4_REACH = 2.0  # |lambda|_max dt <= this (RK4 is stable on the negative real axis up to 2.78)
T_END = 0.5  # s
SAMPLE = 1e-3  # s, tip sampling interval
ANGLE_TIMES = (0.25, 0.5)  # s, stored link angles (and t = 0 as initial angles)

HALF_STEP_TOL = 1e-7  # m, MuJoCo at dt vs dt / 2
INERTIA_TOL = 1e-7  # m, INERTIA vs 100 INERTIA
SCIPY_TOL = 1e-6  # m and rad, MuJoCo vs the SciPy integration of the exact equations


# ----------------------------------------------------------------------------------------
# MuJoCo model (adapter of references.chain_xml / mujoco_model for dynamics)
# ----------------------------------------------------------------------------------------


def dyn_chain_xml(prefix, ch: R.Chain, phi_init, damping, inertia):
    """Nested hinge bodies as in references.chain_xml (qpos = 0 is phi_init, springref makes the
    spring relaxed along the clamp), with point masses at the link tips and dampers d_j."""
    assert ch.disc == "paper"
    r = 0.01 * ch.l
    xml, prev = [], ch.phi0
    for j in range(ch.n):
        delta = float(phi_init[j] - prev)
        if j == 0:
            pos, quat = (ch.start[0], 0.0, ch.start[1]), R.quat_about_minus_y(float(phi_init[0]))
        else:
            pos, quat = (ch.lengths[j - 1], 0.0, 0.0), R.quat_about_minus_y(delta)
        mass = ch.masses[j] + (ch.tip_mass if j == ch.n - 1 else 0.0)  # payload at the last tip
        xml.append(f'<body name="{prefix}{j + 1}" pos="{R.fmt(*pos)}" quat="{R.fmt(*quat)}">')
        xml.append(f'<joint name="{prefix}j{j + 1}" type="hinge" axis="0 -1 0" stiffness="{R.fmt(ch.stiff[j])}" '
                   f'springref="{R.fmt(-delta)}" damping="{R.fmt(damping * ch.damp_ratio[j])}"/>')
        xml.append(f'<inertial pos="{R.fmt(ch.lengths[j], 0, 0)}" mass="{R.fmt(mass)}" '
                   f'diaginertia="{R.fmt(inertia, inertia, inertia)}"/>')
        xml.append(f'<geom type="sphere" size="{R.fmt(r)}" pos="{R.fmt(ch.lengths[j], 0, 0)}" '
                   f'contype="0" conaffinity="0"/>')
        prev = phi_init[j]
    xml.append("</body>" * ch.n)
    return "\n".join(xml)


def dyn_model(chains, inits, dampings, g, dt, inertia=INERTIA, weld=None, weld_tc=None):
    """RK4, no contacts. The weld (references.mujoco_model's, relpose checked at t = 0) is as stiff
    as MuJoCo allows: solref time constant weld_tc (default 2 dt, MuJoCo's floor), impedance 0.9999."""
    bodies = "\n".join(dyn_chain_xml(p, ch, ini, d, inertia) for (p, ch), ini, d in zip(chains, inits, dampings))
    eq = ""
    if weld is not None:
        body1, body2, relpos = weld
        tc = 2 * dt if weld_tc is None else weld_tc
        eq = (f'<equality><weld body1="{body1}" body2="{body2}" relpose="{R.fmt(*relpos, 1, 0, 0, 0)}" '
              f'solref="{R.fmt(tc)} 1" solimp="0.9999 0.9999 0.001 0.5 2"/></equality>')
    xml = f"""<mujoco model="leech-dynamics">
  <compiler angle="radian" inertiafromgeom="false"/>
  <option timestep="{R.fmt(dt)}" gravity="0 0 {R.fmt(-g)}" integrator="RK4"
          solver="Newton" iterations="200" tolerance="1e-15" ls_tolerance="1e-12">
    <flag contact="disable"/>
  </option>
  <worldbody>
{bodies}
  </worldbody>
  {eq}
</mujoco>"""
    return mujoco.MjModel.from_xml_string(xml)


def mujoco_run(chains, inits, dampings, g, dt, inertia=INERTIA, weld=None, weld_tc=None, cons=None):
    """Simulate from rest at qpos = 0 (the initial shape). Returns tip samples (every SAMPLE), the
    absolute angles of each chain at ANGLE_TIMES, the largest weld residual over all steps
    (position m, angle rad; from `cons`, the model's own constraint, if given) and the wall time.
    Raises if MuJoCo reports an instability (it would silently reset the state)."""
    model = dyn_model(chains, inits, dampings, g, dt, inertia, weld, weld_tc)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    if weld is not None:
        assert np.max(np.abs(data.efc_pos)) < 1e-10, "the initial shape must satisfy the weld"
    sizes = [ch.n for _, ch in chains]
    split = np.cumsum(sizes)[:-1]
    first = chains[0][1]
    last = model.body(f"{chains[0][0]}{first.n}").id

    def angles():
        return [ini + np.cumsum(qs) for ini, qs in zip(inits, np.split(data.qpos.copy(), split))]

    def tip():
        # tip of the first chain's last link from MuJoCo's own frames; checked against the angles
        R_ = data.xmat[last].reshape(3, 3)
        p = data.xpos[last] + first.lengths[-1] * R_[:, 0]
        t = np.array([p[0], p[2]])
        assert np.max(np.abs(t - first.tip(angles()[0]))) < 1e-12
        return t

    per_sample = int(round(SAMPLE / dt))
    n_samples = int(round(T_END / SAMPLE))
    keep = {int(round(t / SAMPLE)): str(t) for t in ANGLE_TIMES}
    tips, at, weld_pos, weld_ang = [tip()], {}, 0.0, 0.0
    t0 = time.time()
    for s in range(1, n_samples + 1):
        for _ in range(per_sample):
            mujoco.mj_step(model, data)
            if cons is not None:
                c = cons(np.concatenate(angles()))
                weld_pos = max(weld_pos, float(np.max(np.abs(c[:2]))))
                weld_ang = max(weld_ang, float(abs(c[2])))
        mujoco.mj_forward(model, data)  # frames at the current qpos
        tips.append(tip())
        if s in keep:
            at[keep[s]] = angles()
    bad = data.warning[mujoco.mjtWarning.mjWARN_BADQACC].number
    if bad or not np.all(np.isfinite(data.qpos)):
        raise FloatingPointError(f"MuJoCo unstable at dt = {dt} ({bad} bad accelerations)")
    return np.array(tips), at, (weld_pos, weld_ang), time.time() - t0


# ----------------------------------------------------------------------------------------
# SciPy: the exact equations of motion, written independently of MuJoCo
# ----------------------------------------------------------------------------------------
# Mass point i of a chain sits at start + sum_j a_ij e(phi_j) (a_ij = l_j for j <= i, "paper").
# T = 1/2 sum_i m_i |dp_i|^2 gives M_jk = C_jk cos(phi_j - phi_k), C = sum_i m_i a_i a_i^T, and the
# velocity terms h_j = sum_k C_jk sin(phi_j - phi_k) dphi_k^2. Springs and gravity: -grad V
# (references.Chain.grad); dampers: the same tridiagonal form with d_j on the relative rates.


def integrate_ivp(rhs, y0, times):
    """Radau (the equations are stiff, see DT_CHOICES) at rtol = atol = 1e-12; states at `times`.
    (DOP853 at the same tolerance agreed to 1e-14 but took 20x longer.)"""
    sol = integrate.solve_ivp(rhs, (0.0, times[-1]), y0, method="Radau", t_eval=times, rtol=1e-12, atol=1e-12)
    assert sol.success, sol.message
    return sol.y.T


def damper_matrix(ch: R.Chain, d):
    """D with damper forces -D dphi: sum_j d_j (dphi_j - dphi_{j-1})^2 / 2, dphi_0 = 0."""
    Si = np.eye(ch.n) - np.eye(ch.n, k=-1)  # relative rates from absolute ones
    return Si.T @ np.diag(d * ch.damp_ratio) @ Si


def stiffest_rate(M, K, Dm, Z=None):
    """Largest |eigenvalue| of M x'' + Dm x' + K x = 0 (on the null space Z if constrained) and the
    slowest decay rate."""
    if Z is not None:
        M, K, Dm = Z.T @ M @ Z, Z.T @ K @ Z, Z.T @ Dm @ Z
    ev = R.linear_modes(M, K, Dm)
    return float(np.max(np.abs(ev))), float(-np.max(ev.real))


def pick_dt(rate):
    return next(dt for dt in DT_CHOICES if rate * dt <= RK4_REACH)


class ChainDyn:
    def __init__(self, ch: R.Chain, d):
        self.ch = ch
        n = ch.n
        A = np.tril(np.ones((n, n))) * ch.lengths[None, :]  # row i: lever arms a_ij of mass i
        self.C = (A.T * ch.masses) @ A + ch.tip_mass * np.outer(ch.lengths, ch.lengths)
        self.damp = d * ch.damp_ratio

    def mass_and_bias(self, phi, dphi, g):
        """M and the generalized force Q - h (springs, gravity, dampers, velocity terms)."""
        diff = phi[:, None] - phi[None, :]
        M = self.C * np.cos(diff)
        h = (self.C * np.sin(diff)) @ (dphi * dphi)
        rel = np.diff(np.concatenate([[0.0], dphi]))  # the clamp does not turn
        dr = self.damp * rel
        damper = dr - np.concatenate([dr[1:], [0.0]])
        return M, -self.ch.grad(phi, g) - damper - h


def scipy_chain(ch, d, g, phi_init, times):
    cd = ChainDyn(ch, d)
    n = ch.n

    def rhs(t, y):
        M, f = cd.mass_and_bias(y[:n], y[n:], g)
        return np.concatenate([y[n:], np.linalg.solve(M, f)])

    return integrate_ivp(rhs, np.concatenate([phi_init, np.zeros(n)]), times)[:, :n]


def scipy_body(tc: R.TwoChain, d, g, q_init, times):
    """Index-1 form: [M J^T; J 0] [ddq; -lam] = [f; -gamma], gamma = sum_i C_r,ii dq_i^2 (the weld's
    second derivatives are diagonal, references.TwoChain.cons_hess). The drift of the exact weld is
    returned (largest |C| over the samples, m / rad)."""
    A, B = ChainDyn(tc.A, d), ChainDyn(tc.B, 2 * d)
    nA, n = tc.A.n, tc.A.n + tc.B.n

    def rhs(t, y):
        q, v = y[:n], y[n:]
        MA, fA = A.mass_and_bias(q[:nA], v[:nA], g)
        MB, fB = B.mass_and_bias(q[nA:], v[nA:], g)
        J = tc.cons_jac(q)
        gamma = np.array([np.diag(tc.cons_hess(q, np.eye(3)[r])) @ (v * v) for r in range(3)])
        K = np.zeros((n + 3, n + 3))
        K[:nA, :nA], K[nA:n, nA:n] = MA, MB
        K[:n, n:], K[n:, :n] = J.T, J
        sol = np.linalg.solve(K, np.concatenate([fA, fB, -gamma]))
        return np.concatenate([v, sol[:n]])

    qs = integrate_ivp(rhs, np.concatenate([q_init, np.zeros(n)]), times)[:, :n]
    drift = max(float(np.max(np.abs(tc.cons(q)))) for q in qs)
    return qs, drift


# ----------------------------------------------------------------------------------------
# Cases
# ----------------------------------------------------------------------------------------

G0 = 9.81


def run_chain(name, l, m, k, d, L, phi0_deg, g=G0):
    phi0 = math.radians(phi0_deg)
    ch = R.Chain("paper", l, m, k, L, phi0, np.zeros(2))
    assert np.allclose(ch.elements, l), "whole elements only"
    phi_init = ch.straight()
    times = np.arange(int(round(T_END / SAMPLE)) + 1) / round(1 / SAMPLE)
    M, _ = ChainDyn(ch, d).mass_and_bias(phi_init, np.zeros(ch.n), g)
    rate, decay = stiffest_rate(M, ch.hess(phi_init, g), damper_matrix(ch, d))
    step = pick_dt(rate)
    run = lambda dt, inertia=INERTIA: mujoco_run([("c", ch)], [phi_init], [d], g, dt, inertia)
    tips, at, _, wall = run(step)
    tips_half, _, _, _ = run(step / 2)
    tips_inert, _, _, _ = run(step, 100 * INERTIA)
    t1 = time.time()
    phis = scipy_chain(ch, d, g, phi_init, times)
    wall_sp = time.time() - t1
    tips_sp = np.array([ch.tip(p) for p in phis])
    idx = {key: int(round(float(key) / SAMPLE)) for key in at}
    checks = dict(
        half_step=float(np.max(np.abs(tips - tips_half))),
        inertia=float(np.max(np.abs(tips - tips_inert))),
        scipy_tip=float(np.max(np.abs(tips - tips_sp))),
        scipy_angles=max(float(np.max(np.abs(at[key][0] - phis[i]))) for key, i in idx.items()),
        weld_pos=0.0, weld_ang=0.0, weld_stiffer=0.0, scipy_drift=0.0, wall=wall, wall_scipy=wall_sp,
        travel=float(np.max(np.abs(tips - tips[0]))), rate=rate, decay=decay, dt=step,
    )
    case = dict(name=name, kind="chain", discretization="paper", element_length_m=l, element_mass_kg=m,
                joint_stiffness_nm_per_rad=k, joint_damping_nms_per_rad=d, tube_length_m=L,
                base_angle_deg=phi0_deg, gravity_m_per_s2=g, initial_angles_rad=[float(x) for x in phi_init],
                times_s=[float(t) for t in times], tip_m=[[float(x), float(y)] for x, y in tips],
                angles_at_s={key: [float(x) for x in v[0]] for key, v in at.items()},
                timestep_s=step, integrator="mujoco RK4", body_rotational_inertia_kg_m2=INERTIA,
                stiffest_linear_rate_per_s=rate,
                half_step_difference_m=checks["half_step"], scipy_max_tip_difference_m=checks["scipy_tip"])
    return case, checks


def run_body(name, l, m, k, d, LA, LB, b, c, ms, phi0_deg, g=G0, rng=None):
    phi0 = math.radians(phi0_deg)
    tc = R.TwoChain.make("paper", l, m, k, b, c, ms, phi0, LA, LB)
    assert np.allclose(tc.A.elements, l) and np.allclose(tc.B.elements, l), "whole elements only"
    nA, nB = tc.A.n, tc.B.n
    # initial state: the g = 0 equilibrium, exactly as references.solve_two starts its loading path
    q0, lam0, res0 = tc.minimize(tc.arc(), 0.0)
    assert res0 < R.NEWTON_TOL and tc.reduced_min_eig(q0, lam0, 0.0) > 0, (res0,)
    others0 = R.other_minima_two(tc, 0.0, q0, rng)  # the unloaded shape must be unique
    assert not others0, "more than one stable g = 0 shape"
    a0, b0 = tc.split(q0)
    relpos = (tc.A.lengths[-1] - tc.B.lengths[-1], 0.0, -tc.c)  # B's last frame in A's last frame
    weld = ("a%d" % nA, "b%d" % nB, relpos)
    chains = [("a", tc.A), ("b", tc.B)]
    times = np.arange(int(round(T_END / SAMPLE)) + 1) / round(1 / SAMPLE)

    # linearization at the start (gravity on, g = 0 multipliers): picks the step
    A, B = ChainDyn(tc.A, d), ChainDyn(tc.B, 2 * d)
    M = R.linalg.block_diag(A.mass_and_bias(a0, np.zeros(nA), g)[0], B.mass_and_bias(b0, np.zeros(nB), g)[0])
    Dm = R.linalg.block_diag(damper_matrix(tc.A, d), damper_matrix(tc.B, 2 * d))
    HL = tc.hess(q0, g) - tc.cons_hess(q0, lam0)
    rate, decay = stiffest_rate(M, HL, Dm, R.linalg.null_space(tc.cons_jac(q0)))
    step = pick_dt(rate)

    def run(dt, inertia=INERTIA, weld_tc=2 * step, cons=None):
        return mujoco_run(chains, [a0, b0], [d, 2 * d], g, dt, inertia, weld, weld_tc, cons=cons)

    tips, at, (weld_pos, weld_ang), wall = run(step, cons=tc.cons)
    tips_half, _, _, _ = run(step / 2)  # same weld, half the step: time discretization only
    tips_stiff, _, _, _ = run(step / 2, weld_tc=step)  # weld twice as stiff (its floor at step / 2)
    tips_inert, _, _, _ = run(step, 100 * INERTIA)
    t1 = time.time()
    qs, drift = scipy_body(tc, d, g, q0, times)
    wall_sp = time.time() - t1
    tips_sp = np.array([tc.A.tip(q[:nA]) for q in qs])
    idx = {key: int(round(float(key) / SAMPLE)) for key in at}
    checks = dict(
        half_step=float(np.max(np.abs(tips - tips_half))),
        inertia=float(np.max(np.abs(tips - tips_inert))),
        weld_stiffer=float(np.max(np.abs(tips - tips_stiff))),
        scipy_tip=float(np.max(np.abs(tips - tips_sp))),
        scipy_angles=max(float(np.max(np.abs(np.concatenate(at[key]) - qs[i]))) for key, i in idx.items()),
        weld_pos=weld_pos, weld_ang=weld_ang, scipy_drift=drift, wall=wall, wall_scipy=wall_sp,
        travel=float(np.max(np.abs(tips - tips[0]))), rate=rate, decay=decay, dt=step,
    )
    case = dict(name=name, kind="body", discretization="paper", element_length_m=l, element_mass_kg=m,
                joint_stiffness_nm_per_rad=k, joint_damping_nms_per_rad=d, lengths_m=[LA, LB],
                base_spacing_m=b, tip_spacing_m=c, payload_kg=ms, base_angle_deg=phi0_deg, gravity_m_per_s2=g,
                initial_angles_a_rad=[float(x) for x in a0], initial_angles_b_rad=[float(x) for x in b0],
                times_s=[float(t) for t in times], tip_m=[[float(x), float(y)] for x, y in tips],
                angles_at_s={key: {"a": [float(x) for x in v[0]], "b": [float(x) for x in v[1]]}
                             for key, v in at.items()},
                timestep_s=step, integrator="mujoco RK4", body_rotational_inertia_kg_m2=INERTIA,
                stiffest_linear_rate_per_s=rate,
                weld_solref_timeconst_s=2 * step, half_step_difference_m=checks["half_step"],
                weld_max_violation_m=weld_pos, weld_max_violation_rad=weld_ang,
                scipy_max_tip_difference_m=checks["scipy_tip"])
    return case, checks


def main():
    rng = np.random.default_rng(20240607)
    results = [
        run_chain("chain_n10_flat_k0.05_d0.0005", l=0.01, m=0.001, k=0.05, d=0.0005, L=0.10, phi0_deg=0.0),
        run_body("body_n10_n8_90deg_k0.5_d0.005", l=0.01, m=0.001, k=0.5, d=0.005, LA=0.10, LB=0.08,
                 b=0.017, c=0.012, ms=0.021, phi0_deg=90.0, rng=rng),
    ]
    print(f"\ndynamics (MuJoCo RK4, body inertia {INERTIA:g} kg m^2, 0 to {T_END} s; tip differences in m, "
          f"weld residual in m and rad)")
    print(f"{'case':32s} {'|lam|max':>8s} {'decay':>6s} {'dt':>7s} {'travel':>7s} {'dt/2':>8s} {'100 I':>8s} {'weld 2x':>8s} {'weld m':>8s} {'weld rad':>8s} "
          f"{'SciPy tip':>9s} {'SciPy ang':>9s} {'SciPy C':>8s} {'wall MJ':>7s} {'wall SP':>7s} kept")
    kept = []
    for case, ck in results:
        ok = (ck["half_step"] < HALF_STEP_TOL and ck["inertia"] < INERTIA_TOL
              and ck["scipy_tip"] < SCIPY_TOL and ck["scipy_angles"] < SCIPY_TOL)
        print(f"{case['name']:32s} {ck['rate']:8.2e} {ck['decay']:6.2f} {ck['dt']:7.1e} {ck['travel']:7.4f} {ck['half_step']:8.1e} {ck['inertia']:8.1e} "
              f"{ck['weld_stiffer']:8.1e} {ck['weld_pos']:8.1e} {ck['weld_ang']:8.1e} {ck['scipy_tip']:9.2e} "
              f"{ck['scipy_angles']:9.2e} {ck['scipy_drift']:8.1e} {ck['wall']:7.1f} {ck['wall_scipy']:7.1f} "
              f"{'yes' if ok else 'NO'}")
        if ok:
            kept.append(case)
    OUT.parent.mkdir(parents=True, exist_ok=True)
    OUT.write_text(json.dumps({"generator": GENERATOR, "versions": R.VERSIONS, "cases": kept}, indent=1) + "\n")
    print(f"wrote {OUT.relative_to(R.ROOT)} ({len(kept)} cases)")


if __name__ == "__main__":
    main()
