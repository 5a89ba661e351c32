#!/usr/bin/env python3
"""Independent references for holds and contacts (leech's `stance` module).

Writes crates/leech/tests/data/holds.json, which crates/leech/tests/it/holds_references.rs
compares leech against.

The model is written again here from its equations, not ported from the Rust code:

* Unknowns q = (phi^A_1..phi^A_nA, phi^B_1..phi^B_nB, p0_x, p0_y, phi0): absolute link angles
  (rad, from +x, counter-clockwise), chain A's clamp p0 (m) and the clamp direction phi0 (rad).
  Chain A is clamped at p0, chain B at p0 + b nu(phi0), nu(a) = (sin a, -cos a), both along phi0.
* A tube of length L is cut into n = max(1, ceil(L/l - 1e-9)) elements, the last of length
  e_n = L - (n-1) l, each with one joint: a spring k_j (phi_j - phi_{j-1})^2/2, phi_0 = phi0,
  k_j = k_c min(l / e_j, 1e4) (k_c, m_c = k, m for chain A, 2k, 2m for chain B).
  "paper": link j is element j with a point mass m_c e_j / l at its tip. "midpoint": the joint sits
  in the middle of its element, a rigid root piece e_1/2 leaves the clamp along phi0 (its mass
  m_c e_1 / (2 l) at its middle rides on the driving unit), link j runs from joint j to joint j+1
  ((e_j + e_{j+1})/2, the last e_n/2) with its mass m_c l_j / l at its centre.
  The payload ms sits at chain B's tip, the driving unit's mass Md (with the tubes' tails behind the clamps, rho (L_full - L) each) at p0 + (b/2) nu(phi0).
* V(q) = springs + g (sum of masses times heights).
* Endpoint weld: p_B - p_A - c nu(phi^A_nA) = 0 (2 rows), phi^A_nA - phi^B_nB = 0.
* Rear hold: p0 = P, phi0 = Th.  Front hold: p_A = P_f, phi^A_nA = Th_f.
* Contacts (frictionless): every node (link tip; not the clamps, nor the first joints) keeps the
  tube radius r of clearance from every solid (signed distance >= r); every link keeps r from every
  exposed convex polygon corner (distance from the corner to the segment >= r). With a front hold
  the nodes of each chain's last link are fixed by the hold (plate pose) and the weld: their rows
  are constants of the hold's, a force there is the hold's reaction, and they are left out.

* The single tube (`kind: "chain"`, leech's `stance::tube_in`): one chain of n whole elements with
  its own k, m and a point mass P at its tip (the built-in tube's l, m, r; k and P per case), its
  clamp p0, phi0 the rear hold (the hold's multipliers are the clamp's force and moment about p0),
  no weld, no driving unit. Its contact rows are the body's (every node but the first joint, every
  link against the exposed corners). It is also fed from 0.05 m to its length in 5 mm steps (the
  `feeding_path` of the body, one chain), which must end on the same equilibrium.

Equilibria are constrained minima of V: grad V - J^T lambda = 0 with lambda the multipliers in the
sign convention in which a hold's multipliers are the force (N) and moment (N m) the surface
exerts on the robot, and a contact's multiplier is the normal force (N, >= 0) along the surface's
outward normal. They are found by SciPy `trust-constr` (equalities and inequalities, exact
Hessians), along a path from the unloaded shape (gravity raised in steps, a front target moved in
steps), then polished twice, independently: SLSQP from the trust-constr result (its angles
disturbed by up to 1e-3 rad), and Newton's method on the KKT system of the active set until the
residual is at rounding level. The stored numbers are Newton's; the differences of trust-constr
and SLSQP from them are stored too. A case is written only if Newton converged, the equilibrium is
stable (reduced Hessian positive definite), every contact force is positive, nothing intrudes into
the clearance (exact geometry), and the reactions and contact forces balance the weight.

Run:  validation/.venv/bin/python validation/holds_references.py     (see validation/README.md)
"""

from __future__ import annotations

import json
import math
import sys
import time
import tomllib
import warnings
from pathlib import Path

import numpy as np
import scipy
from scipy import linalg, optimize

ROOT = Path(__file__).resolve().parent.parent
ROBOT_FILE = ROOT / "crates" / "leech" / "robots" / "leech.toml"
# Cup offsets the cases are laid out for (m): faces b + 0.03 = 0.047 m right of
# the clamp and c + 0.02 = 0.032 m right of the endpoint (the scenes below).
CASE_REAR_OFFSET_M = 0.03
CASE_FRONT_OFFSET_M = 0.02
OUT = ROOT / "crates" / "leech" / "tests" / "data" / "holds.json"
GENERATOR = "validation/holds_references.py"

MAX_STIFFNESS_RATIO = 1e4
NEWTON_TOL = 1e-12  # sup norm of the KKT residual: moments over 2k, rows in m over l, rad
ACTIVE_GAP = 1e-5  # after trust-constr, a row this close (m) to its bound and pushing starts in the active set
MARGIN_M = 0.02  # contact pairs farther than this from touching are left out of a solve (then checked)


def cross(u, v):
    """z component of u x v for plane vectors."""
    return u[0] * v[1] - u[1] * v[0]


def e(a):
    return np.array([math.cos(a), math.sin(a)])


def e_prime(a):
    return np.array([-math.sin(a), math.cos(a)])


def nu(a):
    return np.array([math.sin(a), -math.cos(a)])


# ----------------------------------------------------------------------------------------------
# The robot
# ----------------------------------------------------------------------------------------------


def builtin_robot():
    """The built-in robot's values, read from its TOML file (not from the Rust code)."""
    t = tomllib.loads(ROBOT_FILE.read_text())
    assert t["model"]["discretization"] == "paper"
    return dict(
        l=t["tube"]["element_length_m"],
        m=t["tube"]["element_mass_kg"],
        k=t["tube"]["joint_stiffness_nm_per_rad"],
        r=0.5 * t["tube"]["outer_diameter_m"],
        b=t["body"]["base_spacing_m"],
        c=t["body"]["tip_spacing_m"],
        ms=t["body"]["payload_kg"],
        g=t["world"]["gravity_m_per_s2"],
        Md=t["driving_unit"]["mass_kg"],
        # each tube's whole length: the tail behind its clamp rides on the unit
        full=t["tube"].get("full_length_m"),
        # The cases' scenes place the cup faces for these offsets (earlier
        # estimates of the built-in robot's); they are written into the
        # fixture, and the Rust test builds its robot with them.
        rear_offset=CASE_REAR_OFFSET_M,
        front_offset=CASE_FRONT_OFFSET_M,
    )


def tube_robot(robot, stiffness_factor=1.0, tip_mass=0.0):
    """A single tube with the built-in robot's element length, mass and radius, its joint
    stiffness k times `stiffness_factor` and a point mass `tip_mass` (kg) at its tip; the keys of
    `builtin_robot`'s that a one-chain Body reads (no driving unit: Md = 0, b = 0)."""
    return dict(l=robot["l"], m=robot["m"], k=stiffness_factor * robot["k"], r=robot["r"], g=robot["g"],
                P=float(tip_mass), Md=0.0, b=0.0)


def elements(L, l):
    n = max(1, math.ceil(L / l - 1e-9))
    last = L - (n - 1) * l
    assert 0 < last <= l * (1 + 1e-12)
    return np.array([l] * (n - 1) + [last])


# ----------------------------------------------------------------------------------------------
# A row: value, gradient, and a Hessian as a diagonal plus low-rank blocks A^T B A
# ----------------------------------------------------------------------------------------------


class Row:
    __slots__ = ("value", "grad", "diag", "blocks", "info")

    def __init__(self, value, grad, diag, blocks=(), info=None):
        self.value, self.grad, self.diag, self.blocks, self.info = value, grad, diag, list(blocks), info

    def hessian(self, n):
        h = np.diag(self.diag)
        for a, b in self.blocks:
            h += a.T @ b @ a
        return h


# ----------------------------------------------------------------------------------------------
# The floating body
# ----------------------------------------------------------------------------------------------


class Body:
    """Two chains on a floating driving unit; see the module doc."""

    def __init__(self, robot, lengths, disc="paper"):
        """Two lengths: the body. One length: the single tube (see `tube_robot`), its clamp p0,
        phi0 held by the rear hold; no chain B, no weld, no driving unit (Md = 0)."""
        self.R, self.disc = robot, disc
        l = robot["l"]
        self.nc = len(lengths)
        assert self.nc in (1, 2)
        self.el = [elements(L, l) for L in lengths]  # element lengths e_j
        self.n = [len(x) for x in self.el]
        self.first = [0, self.n[0]][:self.nc]
        self.ip = sum(self.n)  # index of p0_x; p0_y = ip + 1, phi0 = ip + 2
        self.N = self.ip + 3
        factor = [1.0, 2.0][:self.nc]  # chain B lumps two tubes
        # one joint per element, its spring from the element's own length
        self.k = [factor[c] * robot["k"] * np.minimum(l / self.el[c], MAX_STIFFNESS_RATIO) for c in range(self.nc)]
        if disc == "paper":
            # link j is element j, its mass at its tip; the first joint at the clamp
            self.links = [x.copy() for x in self.el]
            self.frac, self.root = 1.0, [0.0, 0.0]
        elif disc == "midpoint":
            # joint j in the middle of element j: a rigid root piece e_1/2 along phi0, links from
            # joint to joint, the last from joint n to the tube's end; masses at the links' centres
            self.links = [0.5 * (x + np.r_[x[1:], 0.0]) for x in self.el]
            self.frac, self.root = 0.5, [0.5 * x[0] for x in self.el]
        else:
            raise ValueError(disc)
        self.mass = [factor[c] * robot["m"] * self.links[c] / l for c in range(self.nc)]
        # the root pieces' mass rides on the driving unit, at their middles
        self.root_mass = [factor[c] * robot["m"] * self.root[c] / l for c in range(self.nc)]
        self.tip_mass = [0.0, robot["ms"]] if self.nc == 2 else [robot["P"]]
        self.spacing = [0.0, robot["b"]][:self.nc]
        # the driving unit carries its own mass and the tubes' tails behind the clamps,
        # rho (L_full - L) for each of the three tubes (chain B stands for two)
        tails = sum(factor[c] * (robot["full"] - lengths[c]) for c in range(self.nc)) if robot.get("full") else 0.0
        self.Md = robot["Md"] + robot["m"] / l * tails

    # -- indices and points -------------------------------------------------------------------

    def idx(self, c):
        return np.arange(self.first[c], self.first[c] + self.n[c])

    def last(self, c):
        return self.first[c] + self.n[c] - 1

    def node_weights(self, c, i):
        """Coefficients on e(phi_j) of node i of chain c (0 = the first joint, i = tip of link i)."""
        w = np.zeros(self.n[c])
        w[:i] = self.links[c][:i]
        return w

    def point(self, q, c, w, clamp_weight=1.0, root_weight=None):
        """x = clamp_weight * (p0 + spacing_c nu(phi0)) + root_weight e(phi0) + sum_j w_j e(phi_j)
        (root_weight defaults to clamp_weight times the root piece): value (2,), Jacobian (2, N),
        and the second derivatives (2, N), diagonal: every term depends on one coordinate."""
        N, ip = self.N, self.ip
        if root_weight is None:
            root_weight = clamp_weight * self.root[c]
        idx = self.idx(c)
        phi = q[idx]
        cs, sn = np.cos(phi), np.sin(phi)
        p0, phi0, s = q[ip:ip + 2], q[ip + 2], self.spacing[c]
        x = clamp_weight * (p0 + s * nu(phi0)) + root_weight * e(phi0) + np.array([w @ cs, w @ sn])
        J = np.zeros((2, N))
        J[0, idx], J[1, idx] = -w * sn, w * cs
        J[0, ip], J[1, ip + 1] = clamp_weight, clamp_weight
        J[:, ip + 2] = clamp_weight * s * e(phi0) + root_weight * e_prime(phi0)  # d nu / d a = e
        H = np.zeros((2, N))
        H[0, idx], H[1, idx] = -w * cs, -w * sn
        H[:, ip + 2] = clamp_weight * s * e_prime(phi0) - root_weight * e(phi0)
        return x, J, H

    def node(self, q, c, i):
        return self.point(q, c, self.node_weights(c, i))

    def nodes(self, q, c):
        """The first joint (the clamp for "paper") and every link's tip of chain c."""
        ip = self.ip
        phi = q[self.idx(c)]
        start = q[ip:ip + 2] + self.spacing[c] * nu(q[ip + 2]) + self.root[c] * e(q[ip + 2])
        steps = self.links[c][:, None] * np.stack([np.cos(phi), np.sin(phi)], axis=1)
        return np.vstack([start, start + np.cumsum(steps, axis=0)])

    def endpoint(self, q):
        return self.nodes(q, 0)[-1]

    def unit_point(self, q):
        ip = self.ip
        return q[ip:ip + 2] + 0.5 * self.R["b"] * nu(q[ip + 2])

    def total_mass(self):
        return sum(self.mass[c].sum() + self.root_mass[c] + self.tip_mass[c] for c in range(self.nc)) + self.Md

    def weight(self, g=None):
        return (self.R["g"] if g is None else g) * self.total_mass()

    def centre_of_mass(self, q):
        moment = np.zeros(2)
        ip = self.ip
        for c in range(self.nc):
            pts = self.nodes(q, c)
            centres = pts[:-1] + self.frac * (pts[1:] - pts[:-1])
            moment += self.mass[c] @ centres + self.tip_mass[c] * pts[-1]
            clamp = q[ip:ip + 2] + self.spacing[c] * nu(q[ip + 2])
            moment += self.root_mass[c] * (clamp + 0.5 * self.root[c] * e(q[ip + 2]))
        moment += self.Md * self.unit_point(q)
        return moment / self.total_mass()

    # -- energy -------------------------------------------------------------------------------

    def energy(self, q, g):
        """V, grad V, Hess V."""
        N, ip = self.N, self.ip
        V, grad, H = 0.0, np.zeros(N), np.zeros((N, N))
        for c in range(self.nc):
            idx = self.idx(c)
            D = np.zeros((self.n[c], N))  # relative angles phi_j - phi_{j-1}, phi_0 = phi0
            D[np.arange(self.n[c]), idx] = 1.0
            D[0, ip + 2] -= 1.0
            D[np.arange(1, self.n[c]), idx[:-1]] -= 1.0
            d = D @ q
            V += 0.5 * self.k[c] @ (d * d)
            grad += D.T @ (self.k[c] * d)
            H += D.T @ (self.k[c][:, None] * D)
            # gravity: the mass-weighted sum of the mass points' heights is one "point": on
            # e(phi_j) the weight sum_{i > j} mu_i l_j + mu_j frac l_j + P l_j, on the clamp all
            # the chain's mass, on e(phi0) (the root piece) the links' and payload's mass times
            # its length plus the root mass times half of it
            mu, P = self.mass[c], self.tip_mass[c]
            beyond = np.r_[np.cumsum(mu[::-1])[::-1][1:], 0.0]
            w = self.links[c] * (beyond + self.frac * mu + P)
            total = mu.sum() + P + self.root_mass[c]
            root = (mu.sum() + P) * self.root[c] + self.root_mass[c] * 0.5 * self.root[c]
            y, Jy, Hy = self.point(q, c, w, clamp_weight=total, root_weight=root)
            V += g * y[1]
            grad += g * Jy[1]
            H[np.diag_indices(N)] += g * Hy[1]
        # the driving unit: y = p0_y - (b/2) cos(phi0)
        Md, hb, phi0 = self.Md, 0.5 * self.R["b"], q[ip + 2]
        V += g * Md * (q[ip + 1] - hb * math.cos(phi0))
        grad[ip + 1] += g * Md
        grad[ip + 2] += g * Md * hb * math.sin(phi0)
        H[ip + 2, ip + 2] += g * Md * hb * math.cos(phi0)
        return V, grad, H


# ----------------------------------------------------------------------------------------------
# Equality rows: weld and holds
# ----------------------------------------------------------------------------------------------


def unit_row(body, index, value):
    grad = np.zeros(body.N)
    grad[index] = 1.0
    return Row(value, grad, np.zeros(body.N))


def equality_rows(body, q, rear, front):
    """The weld (3; not for the single tube), then the rear hold (3), then the front hold (3), as
    present. A pose is (x, y, angle_rad)."""
    if body.nc == 1:
        assert front is None
        return [unit_row(body, body.ip + k, q[body.ip + k] - rear[k]) for k in range(3)]
    rows = []
    c = body.R["c"]
    pa, Ja, Ha = body.node(q, 0, body.n[0])
    pb, Jb, Hb = body.node(q, 1, body.n[1])
    ia, ib = body.last(0), body.last(1)
    psi = q[ia]
    dnu, d2nu = e(psi), e_prime(psi)
    for k in range(2):
        grad = Jb[k] - Ja[k]
        grad[ia] -= c * dnu[k]
        diag = Hb[k] - Ha[k]
        diag[ia] -= c * d2nu[k]
        rows.append(Row(pb[k] - pa[k] - c * nu(psi)[k], grad, diag))
    g = np.zeros(body.N)
    g[ia], g[ib] = 1.0, -1.0
    rows.append(Row(q[ia] - q[ib], g, np.zeros(body.N)))
    if rear is not None:
        for k in range(3):
            rows.append(unit_row(body, body.ip + k, q[body.ip + k] - rear[k]))
    if front is not None:
        for k in range(2):
            rows.append(Row(pa[k] - front[k], Ja[k].copy(), Ha[k].copy()))
        rows.append(unit_row(body, ia, q[ia] - front[2]))
    return rows


# ----------------------------------------------------------------------------------------------
# Scenes and contact rows
# ----------------------------------------------------------------------------------------------


class Scene:
    """Half-planes (point, outward normal) and counter-clockwise polygons, from the scene TOML."""

    def __init__(self, text):
        t = tomllib.loads(text)
        self.half_planes = [(np.array(h["point_m"], float), np.array(h["normal"], float)) for h in t.get("half_plane", [])]
        self.polygons = [np.array(p["points_m"], float) for p in t.get("polygon", [])]
        for poly in self.polygons:
            area = 0.5 * sum(cross(poly[i], poly[(i + 1) % len(poly)]) for i in range(len(poly)))
            assert area > 0, "counter-clockwise polygons"
        self.corners = [v for pi, poly in enumerate(self.polygons) for v in self._exposed_convex(pi, poly)]

    def solids(self):
        return [("half_plane", h) for h in self.half_planes] + [("polygon", p) for p in self.polygons]

    def _exposed_convex(self, pi, poly):
        out = []
        n = len(poly)
        for i in range(n):
            d_in, d_out = poly[i] - poly[i - 1], poly[(i + 1) % n] - poly[i]
            if cross(d_in, d_out) <= 0:
                continue  # reflex or straight: no corner sticks out
            others = [s for s in self.solids() if not (s[0] == "polygon" and s[1] is poly)]
            if all(solid_distance(s, poly[i])[0] > 1e-9 for s in others):
                out.append(poly[i].copy())
        return out

    def signed_distance(self, x):
        return min(solid_distance(s, x)[0] for s in self.solids())


def point_in_polygon(x, poly):
    inside = False
    n = len(poly)
    for i in range(n):
        a, b = poly[i], poly[(i + 1) % n]
        if (a[1] > x[1]) != (b[1] > x[1]):
            t = (x[1] - a[1]) / (b[1] - a[1])
            if x[0] < a[0] + t * (b[0] - a[0]):
                inside = not inside
    return inside


def solid_distance(solid, x):
    """Signed distance (m, > 0 in free space) from x to a solid, its gradient in x (2,), its
    Hessian in x (2, 2), and what the closest point lies on."""
    kind, s = solid
    if kind == "half_plane":
        p, n = s
        return float(n @ (x - p)), n.copy(), np.zeros((2, 2)), ("plane", None)
    poly = s
    best = None
    for i in range(len(poly)):
        a, b = poly[i], poly[(i + 1) % len(poly)]
        t = float(np.clip((x - a) @ (b - a) / ((b - a) @ (b - a)), 0.0, 1.0))
        d = float(np.linalg.norm(x - (a + t * (b - a))))
        if best is None or d < best[0]:
            best = (d, i, t)
    d, i, t = best
    sign = -1.0 if point_in_polygon(x, poly) else 1.0
    a, b = poly[i], poly[(i + 1) % len(poly)]
    if 0.0 < t < 1.0:  # inside the edge: the outward normal is the edge direction turned right
        tangent = (b - a) / np.linalg.norm(b - a)
        n = np.array([tangent[1], -tangent[0]])
        return float(n @ (x - a)), n, np.zeros((2, 2)), ("edge", i)
    v = a if t == 0.0 else b
    u = (x - v) / d
    return sign * d, sign * u, sign * (np.eye(2) - np.outer(u, u)) / d, ("vertex", i if t == 0.0 else (i + 1) % len(poly))


class ContactSet:
    """Every (chain, node, solid) and (chain, link, corner) pair, as inequality rows >= 0."""

    def __init__(self, body, scene, pairs=None, fixed=()):
        """`fixed`: the (chain, node) pairs a hold fixes; their rows, and the rows of links
        between two fixed nodes, are constants of the hold's rows (a force there is
        indistinguishable from the hold's reaction) and are left out."""
        self.body, self.scene = body, scene
        if pairs is not None:
            self.pairs = pairs
            return
        self.pairs = []
        for c in range(body.nc):
            for i in range(1, body.n[c] + 1):
                if (c, i) in fixed:
                    continue
                for s in scene.solids():
                    self.pairs.append(("node", c, i, s))
            for j in range(1, body.n[c] + 1):
                if (c, j - 1) in fixed and (c, j) in fixed:
                    continue
                for corner in scene.corners:
                    self.pairs.append(("corner", c, j, corner))

    def near(self, q, margin, keep=None):
        """The pairs within margin (m) of touching at q, plus those of `keep` (a ContactSet)."""
        rows = self.rows(q, with_hessian=False)
        kept = set(id(p) for p in keep.pairs) if keep is not None else set()
        pairs = [p for p, row in zip(self.pairs, rows) if row.value < margin or id(p) in kept]
        return ContactSet(self.body, self.scene, pairs)

    def __len__(self):
        return len(self.pairs)

    def rows(self, q, with_hessian=True):
        body, r = self.body, self.body.R["r"]
        out = []
        for kind, c, i, s in self.pairs:
            if kind == "node":
                x, J, H = body.node(q, c, i)
                d, gx, hx, feature = solid_distance(s, x)
                blocks = [(J, hx)] if with_hessian and np.any(hx) else []
                out.append(Row(d - r, gx @ J, gx @ H, blocks, info=(kind, c, i, 0.0, x, gx)))
            else:
                out.append(self.corner_row(q, c, i, s, with_hessian))
        return out

    def corner_row(self, q, c, j, corner, with_hessian=True):
        """Distance from a corner to link j of chain c, minus r. Inside the link it is the distance
        to the link's line, sigma (a - corner) . nu(phi_j) with a the link's start node, a function
        of a and phi_j alone; beyond either end the distance to that end node."""
        body, r = self.body, self.body.R["r"]
        lj = body.links[c][j - 1]
        ij = body.first[c] + j - 1
        phi = q[ij]
        a, Ja, Ha = body.node(q, c, j - 1)
        s = float(np.clip((corner - a) @ e(phi) / lj, 0.0, 1.0))
        if s in (0.0, 1.0):
            x, J, H = body.node(q, c, j - 1 + int(s))
            gap = x - corner
            d = float(np.linalg.norm(gap))
            u = gap / d
            hx = (np.eye(2) - np.outer(u, u)) / d
            blocks = [(J, hx)] if with_hessian else []
            return Row(d - r, u @ J, u @ H, blocks, info=("corner", c, j, s, x, u))
        lever = (a - corner) @ nu(phi)
        sigma = 1.0 if lever >= 0 else -1.0
        n_vec = sigma * nu(phi)
        grad = n_vec @ Ja
        grad[ij] += sigma * (a - corner) @ e(phi)
        diag = n_vec @ Ha
        diag[ij] += sigma * (a - corner) @ e_prime(phi)
        blocks = []
        if with_hessian:
            # cross terms between a and phi_j: d2/(da dphi) = sigma e(phi)
            Jz = np.vstack([Ja, np.eye(body.N)[ij]])
            Hz = np.zeros((3, 3))
            Hz[0, 2] = Hz[2, 0] = sigma * e(phi)[0]
            Hz[1, 2] = Hz[2, 1] = sigma * e(phi)[1]
            blocks = [(Jz, Hz)]
        x = a + s * lj * e(phi)
        return Row(abs(lever) - r, grad, diag, blocks, info=("corner", c, j, s, x, n_vec))


# ----------------------------------------------------------------------------------------------
# The problem at one stage, and the solvers
# ----------------------------------------------------------------------------------------------


class Problem:
    def __init__(self, body, g, rear=None, front=None, contacts=None):
        self.body, self.g, self.rear, self.front = body, g, rear, front
        self.contacts = contacts if contacts is not None and len(contacts) else None
        self._cache = {}

    def eq(self, q):
        key = ("eq", q.tobytes())
        if key not in self._cache:
            self._cache = {k: v for k, v in self._cache.items() if k[1] == q.tobytes()}
            self._cache[key] = equality_rows(self.body, q, self.rear, self.front)
        return self._cache[key]

    def ineq(self, q):
        key = ("ineq", q.tobytes())
        if key not in self._cache:
            self._cache = {k: v for k, v in self._cache.items() if k[1] == q.tobytes()}
            self._cache[key] = self.contacts.rows(q) if self.contacts else []
        return self._cache[key]

    def n_eq(self):
        return 3 * (self.body.nc == 2) + 3 * (self.rear is not None) + 3 * (self.front is not None)

    def lagrangian_hessian(self, q, lam_eq, mu):
        """Hess V - sum lambda_i Hess C_i - sum mu_i Hess D_i."""
        N = self.body.N
        _, _, H = self.body.energy(q, self.g)
        H = H.copy()
        for lam, rows in ((lam_eq, self.eq(q)), (mu, self.ineq(q))):
            for li, row in zip(lam, rows):
                if li != 0.0:
                    H -= li * row.hessian(N)
        return H

    # -- trust-constr ----------------------------------------------------------------------------

    def trust_constr(self, q0, maxiter=3000, barrier=1e-2):
        N = self.body.N
        fun = lambda q: self.body.energy(q, self.g)[0]
        jac = lambda q: self.body.energy(q, self.g)[1]
        hess = lambda q: self.body.energy(q, self.g)[2]

        def hess_of(rows_fn):
            def h(q, v):
                out = np.zeros((N, N))
                for vi, row in zip(v, rows_fn(q)):
                    if vi != 0.0:
                        out += vi * row.hessian(N)
                return out
            return h

        cons = [optimize.NonlinearConstraint(
            lambda q: np.array([r.value for r in self.eq(q)]), 0.0, 0.0,
            jac=lambda q: np.array([r.grad for r in self.eq(q)]), hess=hess_of(self.eq))]
        if self.contacts:
            cons.append(optimize.NonlinearConstraint(
                lambda q: np.array([r.value for r in self.ineq(q)]), 0.0, np.inf,
                jac=lambda q: np.array([r.grad for r in self.ineq(q)]), hess=hess_of(self.ineq)))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            res = optimize.minimize(fun, q0, jac=jac, hess=hess, method="trust-constr", constraints=cons,
                                    options=dict(gtol=1e-8, xtol=1e-15, barrier_tol=1e-8, maxiter=maxiter,
                                                 initial_barrier_parameter=barrier))
        # SciPy's Lagrangian is f + v^T c: our multipliers are -v.
        lam = -np.asarray(res.v[0])
        mu = -np.asarray(res.v[1]) if self.contacts else np.zeros(0)
        return res.x, lam, mu, res

    # -- SLSQP -----------------------------------------------------------------------------------

    def slsqp(self, q0, maxiter=2000):
        cons = [dict(type="eq", fun=lambda q: np.array([r.value for r in self.eq(q)]),
                     jac=lambda q: np.array([r.grad for r in self.eq(q)]))]
        if self.contacts:
            cons.append(dict(type="ineq", fun=lambda q: np.array([r.value for r in self.ineq(q)]),
                             jac=lambda q: np.array([r.grad for r in self.ineq(q)])))
        res = optimize.minimize(lambda q: self.body.energy(q, self.g)[0], q0,
                                jac=lambda q: self.body.energy(q, self.g)[1], method="SLSQP",
                                constraints=cons, options=dict(ftol=1e-16, maxiter=maxiter))
        m = np.asarray(res.multipliers)  # SciPy's SLSQP: grad f = J^T multipliers, our convention
        ne = self.n_eq()
        return res.x, m[:ne], m[ne:], res

    # -- Newton on the active set ----------------------------------------------------------------

    def kkt_residual(self, q, lam, mu, active=None):
        """Scaled sup norms: stationarity (N m over 2k), equality rows, and for the inequalities the
        worst violation and complementarity (m over l), the most negative force (N)."""
        N, R = self.body.N, self.body.R
        _, grad, _ = self.body.energy(q, self.g)
        r = grad.copy()
        eq = self.eq(q)
        for li, row in zip(lam, eq):
            r -= li * row.grad
        ineq = self.ineq(q)
        for mi, row in zip(mu, ineq):
            r -= mi * row.grad
        scale = np.ones(len(eq))
        if self.body.nc == 1:  # the clamp's rows only
            scale[[0, 1]] = R["l"]
        else:
            scale[[0, 1]] = R["l"]
            if self.rear is not None:
                scale[[3, 4]] = R["l"]
        if self.front is not None:
            scale[[-3, -2]] = R["l"]
        vals = np.array([row.value for row in ineq])
        return dict(
            stationarity=float(np.max(np.abs(r)) / (2 * R["k"])),
            equality=float(np.max(np.abs([row.value for row in eq]) / scale)),
            violation=float(max(0.0, -vals.min()) / R["l"]) if len(vals) else 0.0,
            complementarity=float(np.max(np.abs(mu * vals)) / (2 * R["k"])) if len(vals) else 0.0,
            negative_force=float(max(0.0, -mu.min())) if len(mu) else 0.0,
        )

    def newton(self, q, lam, active_idx, mu_start, maxit=60):
        """Newton on grad V - J_eq^T lambda - J_act^T mu = 0, C_eq = 0, C_act = 0."""
        N = self.body.N
        ne = len(lam)
        y = np.concatenate([lam, mu_start])
        q = q.copy()
        for it in range(maxit):
            eq = self.eq(q)
            ineq = self.ineq(q)
            act = [ineq[i] for i in active_idx]
            rows = eq + act
            J = np.array([row.grad for row in rows])
            _, grad, H = self.body.energy(q, self.g)
            F = np.concatenate([grad - J.T @ y, [row.value for row in rows]])
            mu_full = np.zeros(len(ineq))
            mu_full[active_idx] = y[ne:]
            res = self.kkt_residual(q, y[:ne], mu_full)
            if max(res["stationarity"], res["equality"]) < NEWTON_TOL and \
                    (not len(active_idx) or np.max(np.abs([r.value for r in act])) / self.body.R["l"] < NEWTON_TOL):
                return q, y[:ne], mu_full, it
            L = self.lagrangian_hessian(q, y[:ne], mu_full)
            K = np.block([[L, -J.T], [J, np.zeros((len(rows), len(rows)))]])
            with warnings.catch_warnings():
                # K mixes rad, m and N; its condition estimate is tiny where a node sits in a
                # corner on two rows, and the residual test above decides convergence anyway
                warnings.simplefilter("ignore", linalg.LinAlgWarning)
                step = linalg.solve(K, -F)
            q = q + step[:N]
            y = y + step[N:]
        raise RuntimeError(f"Newton did not converge: {res}")

    def polish(self, q, lam, mu):
        """Newton on the active set guessed from (q, mu), corrected until every active force is
        positive and every inactive row is clear. Should Newton fail from that guess, once more
        with the rows within 100 ACTIVE_GAP in the guess: trust-constr leaves a contact that
        carries little force a slack of about its barrier parameter over the force."""
        try:
            return self._polish(q, lam, mu, ACTIVE_GAP)
        except (linalg.LinAlgError, RuntimeError):
            return self._polish(q, lam, mu, 100 * ACTIVE_GAP)

    def _polish(self, q, lam, mu, gap):
        ineq = self.ineq(q)
        vals = np.array([row.value for row in ineq])
        # A corner row whose closest point is a link's end is the same function as that node's
        # row against the corner's polygon: only the node row may enter the active set.
        own = lambda rows: [i for i, row in enumerate(rows) if not (row.info[0] == "corner" and row.info[3] in (0.0, 1.0))]
        active = [i for i in own(ineq) if vals[i] < gap and mu[i] > 1e-6]
        for _ in range(20):
            qn, lamn, mun, its = self.newton(q, lam, active, mu[active] if len(mu) else np.zeros(0))
            rows = self.ineq(qn)
            vals = np.array([row.value for row in rows])
            neg = [i for i in active if mun[i] <= 0]
            viol = [i for i in own(rows) if i not in active and vals[i] < -1e-13]
            if not neg and not viol:
                return qn, lamn, mun, its, active
            if neg:
                active = [i for i in active if i not in neg]
            else:
                active = sorted(active + viol)
            mu = np.zeros(len(vals))
        raise RuntimeError("active set did not settle")

    def reduced_hessian_min(self, q, lam, mu, active):
        rows = self.eq(q) + [self.ineq(q)[i] for i in active]
        J = np.array([row.grad for row in rows])
        Z = linalg.null_space(J)
        L = self.lagrangian_hessian(q, lam, mu)
        return float(np.linalg.eigvalsh(Z.T @ L @ Z)[0]) if Z.shape[1] else math.inf


def check_derivatives(problem, q, rng):
    """Central differences against every analytic gradient and Hessian (guards the model code)."""
    N, h = problem.body.N, 1e-6
    x = q + rng.normal(0, 0.05, N) * np.r_[np.ones(N - 3), 0.01, 0.01, 1.0]
    _, g, H = problem.body.energy(x, problem.g)
    fd_g = np.array([(problem.body.energy(x + h * ei, problem.g)[0] - problem.body.energy(x - h * ei, problem.g)[0]) / (2 * h) for ei in np.eye(N)])
    fd_H = np.array([(problem.body.energy(x + h * ei, problem.g)[1] - problem.body.energy(x - h * ei, problem.g)[1]) / (2 * h) for ei in np.eye(N)])
    worst = max(np.max(np.abs(fd_g - g)) / max(1, np.max(np.abs(g))), np.max(np.abs(fd_H - H)) / max(1, np.max(np.abs(H))))
    rows = lambda y: problem.eq(y) + problem.ineq(y)
    base = rows(x)
    for k, row in enumerate(base):
        # only where the regime (closest feature) does not switch within +-h
        fd = np.array([(rows(x + h * ei)[k].value - rows(x - h * ei)[k].value) / (2 * h) for ei in np.eye(N)])
        fdh = np.array([(rows(x + h * ei)[k].grad - rows(x - h * ei)[k].grad) / (2 * h) for ei in np.eye(N)])
        worst = max(worst, np.max(np.abs(fd - row.grad)), np.max(np.abs(fdh - row.hessian(N))) / max(1, np.max(np.abs(row.hessian(N)))))
    return worst


# ----------------------------------------------------------------------------------------------
# Paths: from the unloaded shape to the case
# ----------------------------------------------------------------------------------------------


def straight(body, p0, phi0):
    return np.r_[np.full(body.N - 3, phi0), p0, phi0]


def unloaded(body, rear_pose):
    """The g = 0 shape with the rear hold at rear_pose, from both chains straight (infeasible for
    unequal lengths: trust-constr pulls the weld closed)."""
    prob = Problem(body, 0.0, rear=rear_pose)
    q, lam, mu, _ = prob.trust_constr(straight(body, rear_pose[:2], rear_pose[2]))
    q, lam, _, _, _ = prob.polish(q, lam, np.zeros(0))
    return q


def placed(body, q, pose):
    """The shape q moved rigidly so that its endpoint and plate sit on pose (x, y, angle)."""
    turn = pose[2] - q[body.last(0)]
    ip = body.ip
    rot = np.array([[math.cos(turn), -math.sin(turn)], [math.sin(turn), math.cos(turn)]])
    arm = rot @ (body.endpoint(q) - q[ip:ip + 2])
    out = q.copy()
    out[:body.N - 3] += turn
    out[ip + 2] += turn
    out[ip:ip + 2] = np.asarray(pose[:2]) - arm
    return out


def stage(body, q, g, rear, front, everything, label, log, barrier=1e-2):
    """One trust-constr solve from q. The contact rows are the pairs within MARGIN_M of touching
    at q (the far ones cannot matter and slow trust-constr down), widened and solved again until
    no other pair comes within MARGIN_M at the solution. Returns q, the multipliers, SciPy's
    result and the problem (with the rows used)."""
    contacts = everything.near(q, MARGIN_M) if everything is not None else None
    iterations = 0
    for _ in range(10):
        prob = Problem(body, g, rear=rear, front=front, contacts=contacts)
        q1, lam, mu, res = prob.trust_constr(q, barrier=barrier)
        iterations += res.nit
        if everything is None:
            break
        wider = everything.near(q1, MARGIN_M, keep=contacts)
        if len(wider) == len(contacts):
            break
        contacts, q = wider, q1
    rows = f", {len(contacts)} contact rows" if contacts is not None else ""
    log.append(f"{label}: trust-constr status {res.status} after {iterations} iterations{rows}, "
               f"constraint violation {res.constr_violation:.1e}")
    return q1, lam, mu, res, prob


def load_path(body, q, fractions, rear, front, everything, log):
    """Gravity raised to each fraction in turn, each solve warm-started from the last."""
    for f in fractions:
        out = stage(body, q, f * body.R["g"], rear, front, everything, f"g x {f:.2f}", log)
        q = out[0]
    return out


def target_path(body, q, stages, rear, start, front, everything, log):
    """The front hold's target moved from start to front in stages, under full gravity."""
    for s in np.linspace(0, 1, stages + 1)[1:]:
        target = tuple(np.asarray(start) + s * (np.asarray(front) - np.asarray(start)))
        out = stage(body, q, body.R["g"], rear, target, everything, f"front target {s:.2f} of the way", log)
        q = out[0]
    return out


def feeding_path(robot, case, scene, short, step=0.005):
    """A second path to a rear-held contact case, as the robot takes it: from both tubes (or the
    single tube, held at its clamp) at `short` (loaded, from the unloaded shape), fed to the
    case's lengths in steps of at most `step`, each solve warm-started from the last with a new
    link continuing its chain's last one straight (trust-constr, polished by Newton). Returns the
    final body, q and a log."""
    rear, lengths = case["rear"], case["lengths"]
    steps = int(math.ceil((max(lengths) - short) / step - 1e-9))
    log, previous = [], None
    for k in range(steps + 1):
        fed = [short + k / steps * (lengths[c] - short) for c in range(len(lengths))]
        body = Body(robot, fed, case.get("disc", "paper"))
        everything = ContactSet(body, scene)
        if previous is None:
            out = load_path(body, unloaded(body, rear), [1.0], rear, None, everything, [])
        else:
            before, q_before = previous
            chains = []
            for c in range(body.nc):
                old = q_before[before.idx(c)]
                chains.append(np.r_[old, np.full(body.n[c] - len(old), old[-1])][:body.n[c]])
            q = np.concatenate(chains + [q_before[before.ip:]])
            out = stage(body, q, robot["g"], rear, None, everything, "feed", [], barrier=1e-6)
        q, lam, mu, _, prob = out
        q, lam, mu, _, active = prob.polish(q, lam, mu)
        previous = (body, q)
        touching = ", ".join(f"{'ab'[prob.ineq(q)[i].info[1]]}{prob.ineq(q)[i].info[2]} {mu[i]:.3f} N" for i in active)
        log.append(f"{'/'.join(f'{x:.3f}' for x in fed)} m: endpoint ({body.endpoint(q)[0]:.4f}, {body.endpoint(q)[1]:.4f}), "
                   f"plate {q[body.last(0)]:+.4f} rad, touching: {touching or 'nothing'}")
    return body, q, log


# ----------------------------------------------------------------------------------------------
# Cases
# ----------------------------------------------------------------------------------------------


def pose(x, y, deg):
    return (float(x), float(y), math.radians(deg))


WALL_CLIMBED = """name = "the wall the rear cup holds"
[[half_plane]]          # solid at x >= 0.047: the rear cup's face, b + rear_offset right of p0
point_m = [0.047, 0.0]
normal = [-1.0, 0.0]
"""

FLOOR = """name = "floor"
[[half_plane]]          # solid below y = 0
point_m = [0.0, 0.0]
normal = [0.0, 1.0]
"""

def floor_and_wall(x):
    """A floor (solid below y = 0) and a wall (solid at x >= `x`) meeting in an inside corner."""
    return f'''name = "floor and a wall at x = {x:g}"
[[half_plane]]          # the floor
point_m = [0.0, 0.0]
normal = [0.0, 1.0]
[[half_plane]]          # solid at x >= {x:g}
point_m = [{x!r}, 0.0]
normal = [-1.0, 0.0]
'''


FLOOR_AND_WALL_028 = floor_and_wall(0.28)
FLOOR_AND_WALL_020 = floor_and_wall(0.2)

THIN_WALL = """name = "a thin wall under the body"
[[polygon]]             # 20 mm thick, top at y = 0.02 (no floor: all four corners exposed)
points_m = [[0.155, -0.05], [0.175, -0.05], [0.175, 0.02], [0.155, 0.02]]
"""

WALL_AT_FRONT_CUP = """name = "the wall the front cup holds"
[[half_plane]]          # solid at x >= 0.032: the front cup's face, c + front_offset right of the endpoint
point_m = [0.032, 0.0]
normal = [-1.0, 0.0]
"""


FLOOR_UNDER_CLAMP = """name = "floor 30 mm below the clamp"
[[half_plane]]          # solid below y = -0.03
point_m = [0.0, -0.03]
normal = [0.0, 1.0]
"""

THIN_WALL_UNDER_TUBE = """name = "a thin wall under the tube"
[[polygon]]             # 10 mm thick, top 25 mm below the clamp (no floor: all four corners exposed)
points_m = [[0.15, -0.2], [0.16, -0.2], [0.16, -0.025], [0.15, -0.025]]
"""

CHAIN_ELEMENTS = 30


def chain_case(name, values, disc, scene, stiffness_note, checks):
    """A single tube of CHAIN_ELEMENTS whole elements clamped at the origin along +x (the rear
    hold), solved directly and along its feeding path from 0.05 m."""
    return dict(name=name, kind="chain", tube=values, lengths=[CHAIN_ELEMENTS * values["l"]], disc=disc,
                rear=pose(0, 0, 0), scene=scene, feed_from=0.05, stiffness_note=stiffness_note, checks=checks)


def case_list(robot):
    """Each case: name, what it checks, lengths, holds (poses x, y, angle rad), scene TOML, and
    the path the reference takes there."""
    # (c) and (d) hold the front cup where the free endpoint of (a) is: computed first.
    soft = tube_robot(robot, stiffness_factor=0.1, tip_mass=robot["ms"])
    soft_note = "k / 10 (a soft tube, so that several nodes rest on the floor); tip mass the payload ms"
    return [
        dict(name="a_rear_wall", lengths=[0.25, 0.22], rear=pose(0, 0, 90),
             checks="rear hold on a vertical wall: the clamped body, the rear cup carries the weight and the moment"),
        dict(name="a2_rear_tilted_fractional", lengths=[0.2537, 0.2171], rear=pose(0.1, 0.2, 75),
             checks="rear hold off the origin at 75 deg, short last elements (stiffer last springs)"),
        dict(name="b_front_wall", lengths=[0.25, 0.22], front=pose(0, 0.5, 90),
             checks="front hold on a wall: the driving unit hangs from the front cup"),
        dict(name="c_both_free_endpoint", lengths=[0.25, 0.22], rear=pose(0, 0, 90), front="a_rear_wall",
             checks="both holds, the front at (a)'s free endpoint pose: the same shape, zero front reaction"),
        dict(name="d_both_preload", lengths=[0.26, 0.23], rear=pose(0, 0, 90), front="a_rear_wall",
             checks="both holds, tubes 10 mm past (a): a closed loop under preload, both cups loaded"),
        dict(name="f_floor", lengths=[0.30, 0.28], rear=pose(0, robot["b"] + robot["rear_offset"], 0), scene=FLOOR,
             checks="rear cup on a floor, heading 0: the body bends down and rests on the floor"),
        dict(name="g_climbed_wall", lengths=[0.25, 0.22], rear=pose(0, 0, 90), scene=WALL_CLIMBED,
             checks="rear hold on a wall: the body bends into the wall it climbs and leans on it"),
        dict(name="g_floor_wall_028", lengths=[0.28, 0.30], rear=pose(0, robot["b"] + robot["rear_offset"], 0),
             scene=FLOOR_AND_WALL_028,
             checks="rear cup on a floor, body bending up into a wall ahead (x = 0.28) and touching the floor"),
        dict(name="g_floor_wall_020", lengths=[0.30, 0.30], rear=pose(0, robot["b"] + robot["rear_offset"], 0),
             scene=FLOOR_AND_WALL_020, feed_from=0.15,
             checks="rear cup on a floor, equal tubes pushed head-on into a wall at x = 0.2"),
        dict(name="h_thin_wall_corner", lengths=[0.22, 0.22], rear=pose(0, robot["b"] + robot["rear_offset"], 0),
             scene=THIN_WALL,
             checks="the body over a thin wall: a link rests on the wall's far top corner between its nodes"),
        dict(name="i_front_wall_touching", lengths=[0.25, 0.22], front=pose(0, 0.5, 90), scene=WALL_AT_FRONT_CUP,
             checks="front hold on a wall with the hanging body leaning on the wall"),
        dict(name="k_floor_both_free_endpoint", lengths=[0.30, 0.28], rear=pose(0, robot["b"] + robot["rear_offset"], 0),
             front="f_floor", scene=FLOOR,
             checks="both holds on a floor, the front at (f)'s free endpoint pose: (f)'s shape, the front hold "
                    "taking the tip's floor contact"),
        dict(name="k_floor_both_preload", lengths=[0.31, 0.29], rear=pose(0, robot["b"] + robot["rear_offset"], 0),
             front="f_floor", scene=FLOOR,
             checks="both holds on a floor at (f)'s free endpoint pose, tubes 10 mm longer: preload with the body on the floor"),
        dict(name="m_rear_tilted_fractional_midpoint", disc="midpoint", lengths=[0.2537, 0.2171], rear=pose(0.1, 0.2, 75),
             checks="(a2) with the midpoint discretization: rigid root pieces on the driving unit"),
        dict(name="m_front_wall_midpoint", disc="midpoint", lengths=[0.25, 0.22], front=pose(0, 0.5, 90),
             checks="(b) with the midpoint discretization: the root pieces swing with the hanging unit"),
        dict(name="m_floor_midpoint", disc="midpoint", lengths=[0.30, 0.28],
             rear=pose(0, robot["b"] + robot["rear_offset"], 0), scene=FLOOR,
             checks="(f) with the midpoint discretization"),
        # the single tube (stance::tube_in): clamped at the origin along +x, fed from 0.05 m
        chain_case("t_chain_floor", soft, "paper", FLOOR_UNDER_CLAMP, soft_note,
                   "one soft tube with the front cup's mass at its tip, clamped 30 mm above a floor: it sags onto "
                   "the floor and its outer part lies on it, several nodes touching"),
        chain_case("t_chain_floor_midpoint", soft, "midpoint", FLOOR_UNDER_CLAMP, soft_note,
                   "(t_chain_floor) with the midpoint discretization: the rigid root piece, masses at the links' centres"),
        chain_case("t_chain_thin_wall_corner", tube_robot(robot), "paper", THIN_WALL_UNDER_TUBE,
                   "the built-in joint stiffness k",
                   "the built-in tube, no tip mass, over a thin wall: a link rests on the wall's top corner"),
    ]


# What leech did on these cases when the fixture was made: the Rust test checks that it still
# fails so (it reports when a case starts to match, and the mark is then to be removed).
KNOWN_FAILURES = {}


def fixed_nodes(body, front):
    """The nodes a front hold fixes: each chain's last link (its tip and the node before), since
    the hold fixes the plate's pose and the weld the tips on it."""
    if front is None:
        return set()
    return {(c, i) for c in range(2) for i in (body.n[c] - 1, body.n[c]) if i > 0}


def branch_of(body, q, case):
    """A coarse property that tells the branch: the endpoint's offset to the right of the clamp
    direction (m), and for a front hold also the unit's offset right of the plate."""
    ip = body.ip
    p0, phi0 = q[ip:ip + 2], q[ip + 2]
    out = {"endpoint_right_of_clamp_m": float((body.endpoint(q) - p0) @ nu(phi0))}
    if case.get("front") is not None and case.get("rear") is None:
        plate = q[body.last(0)]
        out["unit_right_of_plate_m"] = float((p0 - body.endpoint(q)) @ nu(plate))
    return out


def solve_case(case, robot, done, rng):
    log = []
    values = case.get("tube", robot)  # a single tube's values, or the built-in robot's
    body = Body(values, case["lengths"], case.get("disc", "paper"))
    scene = Scene(case["scene"]) if case.get("scene") else None
    rear = case.get("rear")
    front = case.get("front")
    if isinstance(front, str):  # the free endpoint pose of another case
        other = done[front]
        front = (other["endpoint_m"][0], other["endpoint_m"][1], other["plate_angle_rad"])
    everything = ContactSet(body, scene, fixed=fixed_nodes(body, front)) if scene else None
    # Without contacts gravity is raised in four steps; with contacts at once (every step would
    # cost thousands of interior-point iterations; the branch is checked afterwards).
    loads = [1.0] if everything is not None else [0.25, 0.5, 0.75, 1.0]
    t0 = time.time()
    if rear is not None:
        # the g = 0 shape from straight, then gravity with the rear hold (and the contacts)
        q = unloaded(body, rear)
        log.append("unloaded shape (g = 0, rear hold) from straight")
        if everything is not None:
            pen = -min(r.value for r in everything.rows(q, with_hessian=False))
            log.append(f"the unloaded shape intrudes into the clearance by {max(pen, 0):.3e} m")
        out = load_path(body, q, loads, rear, None, everything, log)
        if front is not None:
            start = (*body.endpoint(out[0]), out[0][body.last(0)])
            out = target_path(body, out[0], 4, rear, start, front, everything, log)
    else:
        q = placed(body, unloaded(body, pose(0, 0, 90)), front)
        log.append("unloaded shape (g = 0) placed on the front hold")
        if everything is not None:
            pen = -min(r.value for r in everything.rows(q, with_hessian=False))
            log.append(f"the unloaded shape intrudes into the clearance by {max(pen, 0):.3e} m")
        out = load_path(body, q, loads, None, front, everything, log)
    q_tc, lam_tc, mu_tc, res_tc, prob = out
    contacts = prob.contacts
    t_tc = time.time() - t0
    # SLSQP from trust-constr's result with every angle disturbed by up to 1e-3 rad, so that it
    # has to find the minimum again rather than stop at once
    kick = np.r_[rng.uniform(-1e-3, 1e-3, body.N - 3), 0.0, 0.0, 0.0]
    q_sl, lam_sl, mu_sl, res_sl = prob.slsqp(q_tc + kick)
    q_nw, lam_nw, mu_nw, its, active = prob.polish(q_tc, lam_tc, mu_tc)
    # trust-constr's interior multipliers on inactive rows are not exactly zero; so compare forces
    resid = {
        "trust_constr": prob.kkt_residual(q_tc, lam_tc, mu_tc),
        "slsqp": prob.kkt_residual(q_sl, lam_sl, mu_sl),
        "newton": prob.kkt_residual(q_nw, lam_nw, mu_nw),
    }
    agree = {
        "trust_constr_vs_newton": {"q": float(np.max(np.abs(q_tc - q_nw))),
                                   "multipliers": float(np.max(np.abs(np.r_[lam_tc - lam_nw, mu_tc - mu_nw])))},
        "slsqp_vs_newton": {"q": float(np.max(np.abs(q_sl - q_nw))),
                            "multipliers": float(np.max(np.abs(np.r_[lam_sl - lam_nw, mu_sl - mu_nw])))},
    }
    feeding = None
    if case.get("feed_from"):
        # the path the robot takes (and leech's solve_in): does it end on the same equilibrium?
        _, q_fed, fed_log = feeding_path(values, case, scene, case["feed_from"])
        feeding = dict(from_m=case["feed_from"], step_m=0.005, max_abs_diff_q=float(np.max(np.abs(q_fed - q_nw))),
                       steps=fed_log)
        log.append(f"feeding path from {case['feed_from']} m: max |q - q_fed| = {feeding['max_abs_diff_q']:.1e}")
    stability = prob.reduced_hessian_min(q_nw, lam_nw, mu_nw, active)
    deriv = check_derivatives(prob, q_nw, rng)
    return body, scene, contacts, prob, (q_nw, lam_nw, mu_nw, active), front, dict(
        residuals=resid, agreement=agree, reduced_hessian_min=stability, newton_iterations=its, feeding_path=feeding,
        derivative_check=deriv, trust_constr=dict(status=int(res_tc.status), iterations=int(res_tc.nit),
                                                  seconds=t_tc),
        slsqp=dict(status=int(res_sl.status), iterations=int(res_sl.nit), message=str(res_sl.message)),
        path=log)


def penetration(body, scene, q):
    """Deepest intrusion into the clearance by exact geometry: nodes against every solid (signed
    distance), every link against every exposed corner, and links crossing a polygon edge."""
    r = body.R["r"]
    worst = -math.inf
    for c in range(body.nc):
        pts = body.nodes(q, c)
        for x in pts[1:]:
            worst = max(worst, r - scene.signed_distance(x))
        for a, b in zip(pts[:-1], pts[1:]):
            for corner in scene.corners:
                t = float(np.clip((corner - a) @ (b - a) / ((b - a) @ (b - a)), 0, 1))
                worst = max(worst, r - float(np.linalg.norm(a + t * (b - a) - corner)))
            for poly in scene.polygons:
                for i in range(len(poly)):
                    if segments_cross(a, b, poly[i], poly[(i + 1) % len(poly)]):
                        worst = max(worst, r)
    return worst


def segments_cross(p1, p2, p3, p4):
    d = lambda a, b, c: cross(b - a, c - a)
    return d(p3, p4, p1) * d(p3, p4, p2) < 0 and d(p1, p2, p3) * d(p1, p2, p4) < 0


def state_fields(body, q, lam):
    """The equilibrium's shape, pose, weld multipliers and weight, as the fixtures store them."""
    ip = body.ip
    return dict(
        angles_a_rad=q[body.idx(0)].tolist(),
        angles_b_rad=q[body.idx(1)].tolist(),
        unit_point_m=q[ip:ip + 2].tolist(),
        unit_angle_rad=float(q[ip + 2]),
        endpoint_m=body.endpoint(q).tolist(),
        plate_angle_rad=float(q[body.last(0)]),
        weld_multipliers=lam[:3].tolist(),
        weight_n=body.weight(),
        centre_of_mass_m=body.centre_of_mass(q).tolist(),
    )


def record(case, robot, body, scene, contacts, prob, sol, front, info):
    q, lam, mu, active = sol
    ip = body.ip
    p0, phi0 = q[ip:ip + 2], q[ip + 2]
    W = body.weight()
    out = dict(
        name=case["name"],
        checks=case["checks"],
        robot="builtin",
        discretization=body.disc,
        lengths_m=case["lengths"],
        elements=body.n,
        hold=("both" if case.get("rear") and front else "rear" if case.get("rear") else "front"),
        rear=None if case.get("rear") is None else dict(point_m=list(case["rear"][:2]), angle_rad=case["rear"][2]),
        front=None if front is None else dict(point_m=[float(front[0]), float(front[1])], angle_rad=float(front[2])),
        scene_toml=case.get("scene"),
        **state_fields(body, q, lam),
    )
    k = 3
    out["rear_reaction"] = None
    if case.get("rear") is not None:
        out["rear_reaction"] = dict(force_n=lam[k:k + 2].tolist(), moment_nm=float(lam[k + 2]))
        k += 3
    out["front_reaction"] = None
    if front is not None:
        out["front_reaction"] = dict(force_n=lam[k:k + 2].tolist(), moment_nm=float(lam[k + 2]))
    # contact forces: the force on the robot is mu times the row's gradient direction in x, which
    # is the surface's outward normal (from a vertex or corner: towards the point)
    contacts_out = []
    if contacts is not None:
        rows = contacts.rows(q, with_hessian=False)
        for i in active:
            kind, c, j, s, x, n = rows[i].info
            node, frac = (j, 0.0) if kind == "node" else ((j - 1, s) if 0 < s < 1 else (j - 1 + int(s), 0.0))
            contacts_out.append(dict(chain="ab"[c], node=int(node), fraction=float(frac), point_m=x.tolist(),
                                     normal=n.tolist(), force_n=float(mu[i])))
    out["contacts"] = contacts_out
    out["fixed_nodes"] = sorted([["ab"[c], i] for c, i in fixed_nodes(body, front)]) if scene else []
    # force and moment balance (about the origin) of all reactions and contact forces against gravity
    F = np.zeros(2)
    M = 0.0

    def add(at, f, m=0.0):
        nonlocal F, M
        F += f
        M += m + at[0] * f[1] - at[1] * f[0]

    if out["rear_reaction"]:
        add(p0, np.array(out["rear_reaction"]["force_n"]), out["rear_reaction"]["moment_nm"])
    if out["front_reaction"]:
        add(body.endpoint(q), np.array(out["front_reaction"]["force_n"]), out["front_reaction"]["moment_nm"])
    for cf in contacts_out:
        add(np.array(cf["point_m"]), cf["force_n"] * np.array(cf["normal"]))
    xg = out["centre_of_mass_m"][0]
    out["balance"] = dict(force_x_rel=float(abs(F[0]) / W), force_y_rel=float(abs(F[1] - W) / W),
                          moment_rel=float(abs(M - xg * W) / (W * 0.3)))
    out["branch"] = branch_of(body, q, case)
    out["penetration_m"] = float(penetration(body, scene, q)) if scene else None
    return with_checks(out, case, info)


def with_checks(out, case, info):
    """`out` with the case's known-failure mark, its stability and the solver's checks appended."""
    if case["name"] in KNOWN_FAILURES:
        out["known_failure"], out["known_failure_contains"] = KNOWN_FAILURES[case["name"]]
    out["reduced_hessian_min"] = info["reduced_hessian_min"]
    out["stable"] = bool(info["reduced_hessian_min"] > 0)
    for key in ("residuals", "agreement", "newton_iterations", "derivative_check", "trust_constr", "slsqp", "path",
                "feeding_path"):
        out[key] = info[key]
    return out


def record_chain(case, body, scene, contacts, sol, info):
    """A single tube's case: what `stance::tube_in` is compared on. The clamp is the rear hold:
    its multipliers are the clamp's force (N) and moment (N m, about the clamp) on the tube."""
    q, lam, mu, active = sol
    R, ip = body.R, body.ip
    W = body.weight()
    clamp = np.asarray(case["rear"][:2])
    pts = body.nodes(q, 0)
    # the centre line as leech lists it: the clamp, the first joint if a root piece lies between
    points = np.vstack([clamp, pts]) if body.root[0] > 0 else pts
    out = dict(
        name=case["name"],
        kind="chain",
        checks=case["checks"],
        tube=dict(elements=body.n[0], element_length_m=R["l"], element_mass_kg=R["m"],
                  joint_stiffness_nm_per_rad=R["k"], tip_mass_kg=R["P"], gravity_m_per_s2=R["g"],
                  radius_m=R["r"], stiffness_note=case["stiffness_note"]),
        discretization=body.disc,
        lengths_m=case["lengths"],
        elements=body.n,
        clamp=dict(point_m=clamp.tolist(), angle_rad=case["rear"][2], base_angle_deg=math.degrees(case["rear"][2])),
        scene_toml=case["scene"],
        angles_rad=q[body.idx(0)].tolist(),
        points_m=points.tolist(),
        tip_m=pts[-1].tolist(),
        weight_n=W,
        centre_of_mass_m=body.centre_of_mass(q).tolist(),
        clamp_reaction=dict(force_n=lam[0:2].tolist(), moment_nm=float(lam[2])),
    )
    contacts_out = []
    rows = contacts.rows(q, with_hessian=False)
    for i in active:
        kind, c, j, s, x, n = rows[i].info
        node, frac = (j, 0.0) if kind == "node" else ((j - 1, s) if 0 < s < 1 else (j - 1 + int(s), 0.0))
        contacts_out.append(dict(node=int(node), fraction=float(frac), point_m=x.tolist(), normal=n.tolist(),
                                 force_n=float(mu[i])))
    out["contacts"] = contacts_out
    # force and moment balance (about the clamp) of the clamp's reaction and the contact forces
    F = lam[0:2].copy()
    M = float(lam[2])
    for cf in contacts_out:
        f = cf["force_n"] * np.array(cf["normal"])
        F += f
        M += cross(np.array(cf["point_m"]) - clamp, f)
    xg = out["centre_of_mass_m"][0] - clamp[0]
    length = sum(case["lengths"])
    out["balance"] = dict(force_x_rel=float(abs(F[0]) / W), force_y_rel=float(abs(F[1] - W) / W),
                          moment_rel=float(abs(M - xg * W) / (W * length)))
    out["branch"] = dict(tip_m=pts[-1].tolist())
    out["penetration_m"] = float(penetration(body, scene, q))
    return with_checks(out, case, info)


def main(argv):
    only = set(argv[1:])
    rng = np.random.default_rng(7)
    robot = builtin_robot()
    t_all = time.time()
    done, cases = {}, []
    previous = json.loads(OUT.read_text())["cases"] if OUT.exists() and only else []
    for case in case_list(robot):
        if only and case["name"] not in only and not any(c["name"] == case["name"] for c in previous):
            continue
        if only and case["name"] not in only:
            kept = next(c for c in previous if c["name"] == case["name"])
            done[case["name"]] = kept
            cases.append(kept)
            continue
        t0 = time.time()
        body, scene, contacts, prob, sol, front, info = solve_case(case, robot, done, rng)
        if case.get("kind") == "chain":
            out = record_chain(case, body, scene, contacts, sol, info)
        else:
            out = record(case, robot, body, scene, contacts, prob, sol, front, info)
        out["seconds"] = time.time() - t0
        r = out["residuals"]
        print(f"{case['name']:28s} {out['seconds']:6.1f} s  newton {r['newton']['stationarity']:.1e}/"
              f"{r['newton']['equality']:.1e}  tc {r['trust_constr']['stationarity']:.1e}  "
              f"slsqp {r['slsqp']['stationarity']:.1e}  tc-newton {out['agreement']['trust_constr_vs_newton']['q']:.1e}  "
              f"slsqp-newton {out['agreement']['slsqp_vs_newton']['q']:.1e}  "
              f"min eig {out['reduced_hessian_min']:.2e}  deriv {out['derivative_check']:.1e}  "
              f"balance {max(out['balance'].values()):.1e}  contacts {len(out['contacts'])}  "
              f"pen {out['penetration_m']}  branch {out['branch']}", flush=True)
        assert out["stable"], case["name"]
        assert r["newton"]["stationarity"] < NEWTON_TOL and r["newton"]["equality"] < NEWTON_TOL
        assert max(out["balance"].values()) < 1e-12, out["balance"]
        assert out["penetration_m"] is None or out["penetration_m"] < 1e-12
        assert out["feeding_path"] is None or out["feeding_path"]["max_abs_diff_q"] < 1e-9
        done[case["name"]] = out
        cases.append(out)
    doc = dict(
        generator=GENERATOR,
        versions={"python": sys.version.split()[0], "numpy": np.__version__, "scipy": scipy.__version__},
        robot=robot,
        description=__doc__.strip().splitlines()[0],
        seconds=sum(c["seconds"] for c in cases),  # of every case, also those kept from a partial run
        cases=cases,
    )
    OUT.write_text(json.dumps(doc, indent=1) + "\n")
    print(f"wrote {OUT.relative_to(ROOT)}: {len(cases)} cases in {time.time() - t_all:.0f} s")


if __name__ == "__main__":
    main(sys.argv)
