#!/usr/bin/env python3
"""Independent references for the three-tube body in 3D (leech's `body3` module, issue 17).

Writes crates/leech/tests/data/body3d.json, which crates/leech/tests/it/body3_references.rs
compares leech against (every link frame to 1e-7 rad, every point to 1e-7 m).

The model is written again here from the issue's equations (docs/model3d.md), not ported from the
Rust code, and parametrized differently:

* World x horizontal, y up, z = x cross y, gravity (0, -g, 0). The driving unit at the origin with
  frame R0 = rotation about z by phi0. Tubes 1, 2, 3 leave it at R0 (0, r_b, 0) and
  R0 (0, -r_b/2, +-r_b sqrt(3)/2), r_b = b / 1.5.
* A tube of length L: n = max(1, ceil(L/l - 1e-9)) links, the last of length e_n = L - (n-1) l,
  a point mass m e_j / l at each link's tip.
* Unknowns: every joint's *relative* rotation vector theta_j (rad), R_j = R_{j-1} Exp(theta_j),
  R_0 = R0 (leech uses the links' absolute frames with local updates instead). The spring energy is
  then sum_j (kt_j theta_x^2 + k_j (theta_y^2 + theta_z^2)) / 2 directly, no logarithm,
  k_j = k min(l / e_j, 1e4), kt_j likewise.
* Gravity: g times every mass's height, the payload ms at the midpoint of tubes 2 and 3's tips.
* The plate: rigid with tube 1's last frame R_P; the tips of tubes 2 and 3 at
  p_1 + R_P (v_i - v_1), v_1 = (0, r_t, 0), v_{2,3} = (0, -r_t/2, +-r_t sqrt(3)/2), r_t = c / 1.5;
  their last frames equal R_P, imposed as vee(R_P^T R_i - R_i^T R_P) / 2 = 0 (leech imposes
  Log(R_P^T R_i) = 0: the same solutions near the weld).
* Derivatives: the gradient of V and the constraints' Jacobian by the complex step (exact to
  rounding, every function above is analytic in theta), the KKT Jacobian by central differences
  of that exact residual.

The path is the documented one: the tubes fed at g = 0 from the shortest length (every tube's
links scaled by (L_min + tau (L_i - L_min)) / L_i, tau from 0 to 1), then gravity raised from 0 to g.

Method 1: Newton on the KKT system grad V - J^T lambda = 0, C = 0 along that path (fixed steps,
halved when Newton fails), polished to a residual of 1e-13; the reduced Hessian (central
differences of the exact gradient, projected on the null space of J) checked positive definite.
Method 2 (cross-check): SLSQP minimization of V under the constraints at full load, started from
the unloaded shape at the body's lengths (end of the feeding path); its largest frame difference
from method 1 is recorded.

Run: python3 validation/body3d_references.py   (numpy, scipy; see requirements.txt)
"""

import json
import math
import multiprocessing
import os

import numpy as np
import scipy
from scipy.optimize import minimize

H_COMPLEX = 1e-30


def rot_z(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def hat(v):
    """[v] for a batch of vectors v (..., 3)."""
    z = np.zeros_like(v[..., 0])
    return np.stack(
        [
            np.stack([z, -v[..., 2], v[..., 1]], -1),
            np.stack([v[..., 2], z, -v[..., 0]], -1),
            np.stack([-v[..., 1], v[..., 0], z], -1),
        ],
        -2,
    )


def expm_batch(v):
    """Rodrigues' formula, analytic in v (t^2 = v . v without conjugation)."""
    t2 = np.sum(v * v, axis=-1)
    small = np.abs(t2) < 1e-6
    safe = np.where(small, 1.0, t2)
    t = np.sqrt(safe)
    a = np.where(small, 1 - t2 / 6 + t2 * t2 / 120, np.sin(t) / t)
    b = np.where(small, 0.5 - t2 / 24 + t2 * t2 / 720, (1 - np.cos(t)) / safe)
    h = hat(v)
    eye = np.broadcast_to(np.eye(3), h.shape)
    return eye + a[..., None, None] * h + b[..., None, None] * (h @ h)


class Body:
    def __init__(self, case):
        self.c = case
        l = case["element_length_m"]
        self.l = l
        self.R0 = rot_z(math.radians(case["base_angle_deg"]))
        rb, rt = case["base_spacing_m"] / 1.5, case["tip_spacing_m"] / 1.5
        s3 = math.sqrt(3) / 2
        tri = lambda r: [np.array([0, r, 0.0]), np.array([0, -r / 2, r * s3]), np.array([0, -r / 2, -r * s3])]
        self.roots = [self.R0 @ v for v in tri(rb)]
        self.plate = tri(rt)
        self.lengths, self.k, self.kt, self.masses = [], [], [], []
        for L in case["lengths_m"]:
            n = max(1, math.ceil(L / l - 1e-9))
            e = [l] * n
            e[-1] = L - (n - 1) * l
            ratio = [min(l / ej, 1e4) for ej in e]
            self.lengths.append(np.array(e))
            self.k.append(np.array([case["joint_stiffness_nm_per_rad"] * r for r in ratio]))
            self.kt.append(np.array([case["torsion_stiffness_nm_per_rad"] * r for r in ratio]))
            self.masses.append(np.array([case["element_mass_kg"] * ej / l for ej in e]))
        self.n = [len(x) for x in self.lengths]
        self.dim = 3 * sum(self.n)

    def split(self, x):
        """(..., dim) -> per tube (..., n_i, 3)."""
        out, at = [], 0
        for n in self.n:
            out.append(x[..., at : at + 3 * n].reshape(x.shape[:-1] + (n, 3)))
            at += 3 * n
        return out

    def frames(self, x):
        """Per tube, the frames (..., n_i, 3, 3)."""
        out = []
        for th in self.split(x):
            ex = expm_batch(th)
            r = np.broadcast_to(self.R0, th.shape[:-2] + (3, 3)).astype(th.dtype)
            fs = []
            for j in range(th.shape[-2]):
                r = r @ ex[..., j, :, :]
                fs.append(r)
            out.append(np.stack(fs, -3))
        return out

    def evaluate(self, x, load, scale):
        """Energy (...,) and constraints (..., 12) at joint vectors x (..., dim)."""
        g = self.c["gravity_m_per_s2"] * load
        fr = self.frames(x)
        energy = 0.0
        tips = []
        for i, (th, f) in enumerate(zip(self.split(x), fr)):
            energy = energy + 0.5 * np.sum(
                self.kt[i] * th[..., 0] ** 2 + self.k[i] * (th[..., 1] ** 2 + th[..., 2] ** 2), axis=-1
            )
            steps = scale[i] * self.lengths[i][:, None] * f[..., :, :, 0]  # (..., n, 3)
            pts = self.roots[i] + np.cumsum(steps, axis=-2)
            energy = energy + g * np.sum(self.masses[i] * pts[..., 1], axis=-1)
            tips.append(pts[..., -1, :])
        ms = self.c["payload_kg"]
        energy = energy + g * ms * 0.5 * (tips[1][..., 1] + tips[2][..., 1])
        rp = fr[0][..., -1, :, :]
        rows = []
        for side in (1, 2):
            off = self.plate[side] - self.plate[0]
            rows.append(tips[side] - tips[0] - np.einsum("...ij,j->...i", rp, off))
            m = np.swapaxes(rp, -1, -2) @ fr[side][..., -1, :, :]
            a = 0.5 * (m - np.swapaxes(m, -1, -2))
            rows.append(np.stack([a[..., 2, 1], a[..., 0, 2], a[..., 1, 0]], -1))
        return energy, np.concatenate(rows, -1)

    def gradients(self, x, load, scale):
        """Exact grad V and J by the complex step (one batch of dim perturbations)."""
        batch = x[None, :] + 1j * H_COMPLEX * np.eye(self.dim)
        e, c = self.evaluate(batch, load, scale)
        return np.imag(e) / H_COMPLEX, (np.imag(c) / H_COMPLEX).T  # (dim,), (12, dim)

    def residual(self, z, load, scale):
        x, lam = z[: self.dim], z[self.dim :]
        grad, jac = self.gradients(x, load, scale)
        _, c = self.evaluate(x, load, scale)
        return np.concatenate([(grad - jac.T @ lam) / self.c["joint_stiffness_nm_per_rad"], c / self.scales()])

    def scales(self):
        return np.array(([self.l] * 3 + [1.0] * 3) * 2)

    def gradients_around(self, x, load, scale, h):
        """grad V - J^T lambda's parts at x + h e_i and x - h e_i for every i, in one batch:
        gradients (2 dim, dim), Jacobians (2 dim, 12, dim), constraints (2 dim, 12)."""
        shifted = np.concatenate([x + h * np.eye(self.dim), x - h * np.eye(self.dim)])
        batch = shifted[:, None, :] + 1j * H_COMPLEX * np.eye(self.dim)[None, :, :]
        e, c = self.evaluate(batch, load, scale)
        _, c_real = self.evaluate(shifted, load, scale)
        return np.imag(e) / H_COMPLEX, np.swapaxes(np.imag(c) / H_COMPLEX, -1, -2), c_real

    def kkt_jacobian(self, z, load, scale):
        """Central differences in x of the exact residual (one batch); its lambda columns are -J^T / k, 0."""
        h = 1e-7
        x, lam = z[: self.dim], z[self.dim :]
        k = self.c["joint_stiffness_nm_per_rad"]
        grads, jacs, cons = self.gradients_around(x, load, scale, h)
        res = np.concatenate([(grads - np.einsum("brd,r->bd", jacs, lam)) / k, cons / self.scales()], axis=1)
        cols = (res[: self.dim] - res[self.dim :]) / (2 * h)
        _, jac = self.gradients(x, load, scale)
        lam_cols = np.vstack([-jac.T / k, np.zeros((12, 12))])
        return np.hstack([cols.T, lam_cols])

    def newton(self, z, load, scale, tol=1e-13, max_iter=60):
        """Newton's method with the KKT Jacobian refreshed every few steps
        (a chord method in between: it only sets the rate, the residual is exact)."""
        lu = None
        for it in range(max_iter):
            r = self.residual(z, load, scale)
            if np.max(np.abs(r)) < tol:
                return z, True
            if it % 6 == 0:
                lu = scipy.linalg.lu_factor(self.kkt_jacobian(z, load, scale))
            step = scipy.linalg.lu_solve(lu, -r)
            if np.max(np.abs(step[: self.dim])) > 0.5:
                return z, False
            z = z + step
        r = self.residual(z, load, scale)
        return z, np.max(np.abs(r)) < 1e-11

    def reduced_hessian_min(self, z, load, scale):
        x, lam = z[: self.dim], z[self.dim :]
        h = 1e-6
        grads, jacs, _ = self.gradients_around(x, load, scale, h)
        lagrangian = grads - np.einsum("brd,r->bd", jacs, lam)
        hess = ((lagrangian[: self.dim] - lagrangian[self.dim :]) / (2 * h)).T
        hess = 0.5 * (hess + hess.T)
        _, jac = self.gradients(x, load, scale)
        null = scipy.linalg.null_space(jac)
        return float(np.min(np.linalg.eigvalsh(null.T @ hess @ null)))

    def follow(self, z, path, steps=4):
        """Newton along path(tau), tau in [0, 1], steps halved on failure."""
        tau, dtau = 0.0, 1.0 / steps
        z, ok = self.newton(z, *path(0.0))
        assert ok, "start"
        while tau < 1 - 1e-15:
            dtau = min(dtau, 1 - tau)
            trial, ok = self.newton(z.copy(), *path(tau + dtau))
            if ok:
                z, tau = trial, tau + dtau
            else:
                dtau *= 0.5
                assert dtau > 1e-4, "path failed"
        return z


def solve(case):
    body = Body(case)
    L = case["lengths_m"]
    lmin = min(L)
    feed = lambda tau: (0.0, [(lmin + tau * (li - lmin)) / li for li in L])
    load = lambda t: (t, [1.0, 1.0, 1.0])
    z = np.zeros(body.dim + 12)
    z = body.follow(z, feed)
    unloaded = z.copy()
    if case["gravity_m_per_s2"] > 0:
        z = body.follow(z, load)
    assert body.reduced_hessian_min(z, 1.0, [1.0] * 3) > 0, "method 1 ended unstable"

    # Method 2: SLSQP from the unloaded shape, gravity on at once.
    def fun(x):
        e, _ = body.evaluate(x, 1.0, [1.0] * 3)
        g, _ = body.gradients(x, 1.0, [1.0] * 3)
        return float(e), g

    cons = {
        "type": "eq",
        "fun": lambda x: body.evaluate(x, 1.0, [1.0] * 3)[1] / body.scales(),
        "jac": lambda x: body.gradients(x, 1.0, [1.0] * 3)[1] / body.scales()[:, None],
    }
    second = minimize(fun, unloaded[: body.dim], jac=True, constraints=[cons], method="SLSQP",
                      options={"ftol": 1e-15, "maxiter": 300})
    f1 = body.frames(z[: body.dim])
    f2 = body.frames(second.x)
    diff = max(float(np.max(np.abs(a - b))) for a, b in zip(f1, f2))

    out = dict(case)
    tubes = []
    for i, f in enumerate(f1):
        steps = body.lengths[i][:, None] * f[:, :, 0]
        pts = np.vstack([body.roots[i], body.roots[i] + np.cumsum(steps, axis=0)])
        tubes.append({"frames": f.tolist(), "points_m": pts.tolist()})
    out["tubes"] = tubes
    out["max_residual"] = float(np.max(np.abs(body.residual(z, 1.0, [1.0] * 3))))
    out["slsqp_max_frame_diff"] = diff
    return out


BUILTIN = {
    "element_length_m": 0.01,
    "element_mass_kg": 0.001,
    "joint_stiffness_nm_per_rad": 0.5,
    "torsion_stiffness_nm_per_rad": 0.5 / 1.3,
    "base_spacing_m": 0.017,
    "tip_spacing_m": 0.012,
    "payload_kg": 0.021,
    "gravity_m_per_s2": 9.81,
    "base_angle_deg": 90.0,
}

CASES = [
    dict(BUILTIN, name="turning_up_a_wall", lengths_m=[0.10, 0.115, 0.085]),
    dict(BUILTIN, name="turning_on_a_horizontal_heading", base_angle_deg=0.0, lengths_m=[0.10, 0.08, 0.115]),
    dict(BUILTIN, name="twist_coupling_soft_torsion", base_angle_deg=45.0, torsion_stiffness_nm_per_rad=0.1,
         lengths_m=[0.09, 0.11, 0.075]),
    dict(BUILTIN, name="unloaded_turning", gravity_m_per_s2=0.0, lengths_m=[0.08, 0.12, 0.095]),
    dict(BUILTIN, name="soft_body_pi204", joint_stiffness_nm_per_rad=0.02, torsion_stiffness_nm_per_rad=0.02 / 1.3,
         lengths_m=[0.09, 0.10, 0.08]),
]


def report(case):
    out = solve(case)
    print(f"{case['name']}: residual {out['max_residual']:.1e}, "
          f"SLSQP differs by {out['slsqp_max_frame_diff']:.1e}", flush=True)
    return out


def main():
    # The cases are independent: two at a time.
    with multiprocessing.Pool(2) as pool:
        cases = pool.map(report, CASES)
    data = {
        "generator": "validation/body3d_references.py",
        "versions": {"numpy": np.__version__, "scipy": scipy.__version__},
        "cases": cases,
    }
    here = os.path.dirname(os.path.abspath(__file__))
    path = os.path.join(here, "..", "crates", "leech", "tests", "data", "body3d.json")
    with open(path, "w") as f:
        json.dump(data, f, indent=1)


if __name__ == "__main__":
    main()
