#!/usr/bin/env python3
"""Independent references for the driving unit's outline (leech's `stance::Unit`): the front cup
holds, the rear cup does not, and the hanging driving unit rests on a scene's solids by its
outline (a corner on a surface, a solid's corner on one of its edges).

Writes crates/leech/tests/data/unit.json, which crates/leech/tests/it/unit_references.rs compares
leech against.

The body, its potential, the weld, the front hold and the tubes' contacts are holds_references.py's
(imported, not copied). What is added here is the driving unit's rigid geometry, written from
docs/model.md section 7.3.3 and not from the Rust code. A point (a, c) of the unit's frame (a along
the clamp direction e(phi0), c across along nu(phi0), from chain A's clamp p0) is in the world at

    x = p0 + a e(phi0) + c nu(phi0)                                               (m)

The outline is the rectangle of the robot file's [driving_unit] (length, height, back, top): corners
(-back, -top), (length - back, -top), (length - back, height - top), (-back, height - top). The rear
cup's face is the segment across d = b + rear_offset from p0, centred rear_cup_behind behind it,
half the cup's diameter each way. Both touch with no clearance:

* every outline corner and each end of the rear cup's face (a rim) keeps a signed distance >= 0
  from every solid (holds_references' exact distance: half-planes, polygons' edges and vertices);
* every exposed convex corner p of a polygon keeps outside the outline: n_k(phi0) . (p - v_k) >= 0
  for the edge k the corner faces (n_k its outward normal, v_k its first corner; the edge is the one
  with the largest value when the rows are chosen, and a stored case has each active corner's foot
  inside its edge), and on the far side of the rear cup's face: nu(phi0) . (p - x_face) >= 0.

These rows' derivatives are exact (first and second, the cross terms between p0 and phi0
included). The hose's stop of leech's solves among solids does not act in a stored case (every
joint short of 80 % of its stop, checked).

Each case is solved as holds_references solves a front-held case: the unloaded shape placed on the
front hold, gravity applied with every row within reach, trust-constr, then SLSQP from it and
Newton on the active set. A case is written only if Newton's KKT residual is at rounding level,
SLSQP agrees, the equilibrium is stable, every contact force is positive, the unit's outline carries
a load, nothing intrudes (exact geometry: the tubes' clearance, the outline's corners and the rims
out of every solid, no exposed corner inside the outline), and the front reaction and the contact
forces balance the weight to 1e-12.

Run:  validation/.venv/bin/python validation/unit_references.py     (see validation/README.md)
"""

from __future__ import annotations

import json
import math
import sys
import time
import tomllib
from pathlib import Path

import numpy as np
import scipy

sys.path.insert(0, str(Path(__file__).resolve().parent))
import holds_references as H  # noqa: E402  (the floating body, the front hold, the solvers)
from holds_references import Row, e, e_prime, nu  # noqa: E402

OUT = H.ROOT / "crates" / "leech" / "tests" / "data" / "unit.json"
GENERATOR = "validation/unit_references.py"
STOP_FRACTION = 0.8  # leech gives a joint a stop row past this fraction of its stop


def robot_values():
    """holds_references' robot with the built-in cups and driving unit, from leech.toml."""
    t = tomllib.loads(H.ROBOT_FILE.read_text())
    robot = H.builtin_robot()
    unit = t["driving_unit"]
    robot.update(rear_offset=t["cup"]["rear_offset_m"], front_offset=t["cup"]["front_offset_m"],
                 cup_diameter=t["cup"]["diameter_m"], min_bend_radius=t["tube"]["min_bend_radius_m"],
                 unit_length=unit["length_m"], unit_height=unit["height_m"], unit_back=unit["back_m"],
                 unit_top=unit["top_m"], rear_cup_behind=unit["rear_cup_behind_m"])
    return robot


class Unit:
    """The driving unit's outline and rear cup face in its own frame (a, c)."""

    def __init__(self, robot):
        L, h, back, top = robot["unit_length"], robot["unit_height"], robot["unit_back"], robot["unit_top"]
        self.corners = np.array([[-back, -top], [L - back, -top], [L - back, h - top], [-back, h - top]])
        centre = self.corners.mean(axis=0)
        self.edges = []
        for k in range(4):
            a, b = self.corners[k], self.corners[(k + 1) % 4]
            t = (b - a) / np.linalg.norm(b - a)
            n = np.array([t[1], -t[0]])
            if n @ (a - centre) < 0:
                n = -n
            self.edges.append((a, b, n))
        d, w, behind = robot["b"] + robot["rear_offset"], 0.5 * robot["cup_diameter"], robot["rear_cup_behind"]
        self.rims = np.array([[-behind - w, d], [-behind + w, d]])
        # the face as an "edge" whose outward side is the cup's (+nu): a corner stays beyond it
        self.face = (self.rims[0], self.rims[1], np.array([0.0, 1.0]))


def frame(local, phi0):
    """The world offset of local (a, c) and its first two derivatives in phi0."""
    a, c = local
    return a * e(phi0) + c * nu(phi0), a * e_prime(phi0) + c * e(phi0), -a * e(phi0) + c * e_prime(phi0)


def unit_point(body, q, local):
    """x = p0 + a e(phi0) + c nu(phi0): value, Jacobian (2, N), second derivatives (2, N) (only
    phi0's; the point is linear in p0)."""
    ip = body.ip
    off, d1, d2 = frame(local, q[ip + 2])
    x = q[ip:ip + 2] + off
    J = np.zeros((2, body.N))
    J[0, ip], J[1, ip + 1] = 1.0, 1.0
    J[:, ip + 2] = d1
    Hd = np.zeros((2, body.N))
    Hd[:, ip + 2] = d2
    return x, J, Hd


class UnitSet(H.ContactSet):
    """holds_references' tube pairs plus the unit's: ("corner", k, solid), ("rim", side, solid),
    ("edge", k, p) for an exposed corner p against outline edge k, ("face", p) against the rear
    cup's face."""

    def __init__(self, body, scene, unit, pairs=None, fixed=()):
        super().__init__(body, scene, pairs=pairs, fixed=fixed)
        self.unit = unit
        if pairs is not None:
            return
        for s in scene.solids():
            self.pairs += [("ucorner", k, s, None) for k in range(4)] + [("rim", i, s, None) for i in (0, 1)]
        for p in scene.corners:
            self.pairs += [("edge", k, p, None) for k in range(4)] + [("face", 0, p, None)]

    def near(self, q, margin, keep=None):
        """The pairs within margin (m) of touching, plus those of `keep`; of a corner's edge pairs
        only the edge it faces (the largest value)."""
        rows = self.rows(q, with_hessian=False)
        kept = set(id(p) for p in keep.pairs) if keep is not None else set()
        facing = {}
        for i, (pair, row) in enumerate(zip(self.pairs, rows)):
            if pair[0] == "edge":
                key = id(pair[2])
                if key not in facing or row.value > rows[facing[key]].value:
                    facing[key] = i
        chosen = []
        for i, (pair, row) in enumerate(zip(self.pairs, rows)):
            if pair[0] == "edge" and facing[id(pair[2])] != i and id(pair) not in kept:
                continue
            # The cup's face is a segment, not a half-plane: a corner only where its foot is on it.
            if pair[0] == "face" and id(pair) not in kept and not (0 < row.info[2] < 1 and row.value > -margin):
                continue
            if row.value < margin or id(pair) in kept:
                chosen.append(pair)
        return UnitSet(self.body, self.scene, self.unit, chosen)

    def rows(self, q, with_hessian=True):
        tubes = [p for p in self.pairs if p[0] in ("node", "corner")]
        out = H.ContactSet(self.body, self.scene, tubes).rows(q, with_hessian) if tubes else []
        by_pair = iter(out)
        rows = []
        for pair in self.pairs:
            kind = pair[0]
            if kind in ("node", "corner"):
                rows.append(next(by_pair))
            elif kind in ("ucorner", "rim"):
                local = (self.unit.corners if kind == "ucorner" else self.unit.rims)[pair[1]]
                x, J, Hd = unit_point(self.body, q, local)
                d, gx, hx, _ = H.solid_distance(pair[2], x)
                blocks = [(J, hx)] if with_hessian and np.any(hx) else []
                chain = "unit" if kind == "ucorner" else "rear_cup"
                rows.append(Row(d, gx @ J, gx @ Hd, blocks, info=(chain, pair[1], 0.0, x, gx)))
            else:
                edge = self.unit.edges[pair[1]] if kind == "edge" else self.unit.face
                rows.append(self.edge_row(q, edge, pair[2], "unit" if kind == "edge" else "rear_cup",
                                          pair[1], with_hessian))
        return rows

    def edge_row(self, q, edge, p, chain, k, with_hessian):
        """f = n(phi0) . (p - p0) - n_loc . a_loc for the edge (a_loc, b_loc, n_loc) of the unit:
        the corner p on the edge's outer side. df/dp0 = -n, df/dphi0 = n' . (p - p0),
        d2f/dphi0^2 = n'' . (p - p0), d2f/dp0 dphi0 = -n'."""
        body, ip = self.body, self.body.ip
        a_loc, b_loc, n_loc = edge
        p0, phi0 = q[ip:ip + 2], q[ip + 2]
        n, n1, n2 = frame(n_loc, phi0)
        arm = p - p0
        value = float(n @ arm - n_loc @ a_loc)
        grad = np.zeros(body.N)
        grad[ip:ip + 2] = -n
        grad[ip + 2] = n1 @ arm
        diag = np.zeros(body.N)
        diag[ip + 2] = n2 @ arm
        blocks = []
        if with_hessian:
            Jz = np.eye(body.N)[ip:ip + 3]
            Hz = np.zeros((3, 3))
            Hz[0, 2] = Hz[2, 0] = -n1[0]
            Hz[1, 2] = Hz[2, 1] = -n1[1]
            blocks = [(Jz, Hz)]
        # where on the edge the corner's foot lies, and the force's direction on the robot (-n)
        a_w, b_w = p0 + frame(a_loc, phi0)[0], p0 + frame(b_loc, phi0)[0]
        s = float((p - a_w) @ (b_w - a_w) / ((b_w - a_w) @ (b_w - a_w)))
        return Row(value, grad, diag, blocks, info=(chain, k, s, np.asarray(p, float), -n))


def unit_penetration(body, scene, unit, q):
    """The deepest intrusion (m, > 0 inside) by exact geometry: the tubes' (holds_references), the
    outline's corners and the rims in a solid, an exposed corner inside the outline."""
    worst = H.penetration(body, scene, q)
    ip = body.ip
    p0, phi0 = q[ip:ip + 2], q[ip + 2]
    for local in list(unit.corners) + list(unit.rims):
        worst = max(worst, -scene.signed_distance(p0 + frame(local, phi0)[0]))
    for p in scene.corners:
        depth = min(-(frame(n, phi0)[0] @ (p - p0 - frame(a, phi0)[0])) for a, _, n in unit.edges)
        worst = max(worst, depth)
    return worst


def near_stop(body, q, robot):
    """The largest joint turn as a fraction of the hose's stop l / R_min."""
    beta_max = robot["l"] / robot["min_bend_radius"]
    ip = body.ip
    worst = 0.0
    for c in range(body.nc):
        at = body.idx(c)
        before = np.r_[ip + 2, at[:-1]]
        worst = max(worst, float(np.max(np.abs(q[at] - q[before]))) / beta_max)
    return worst


# ----------------------------------------------------------------------------------------------
# Cases
# ----------------------------------------------------------------------------------------------


def case_list(robot):
    """Front hold on a vertical wall (solid at x >= 0; the front cup's face on it, the plate up):
    the body hangs from it, the unit below, and a ledge under the unit catches it."""
    d_front = robot["c"] + robot["front_offset"]

    def ledge(x_edge, y_top, depth=0.1):
        """A block on the wall's face under the unit: its top at y_top, its free edge at x_edge."""
        return f'''name = "a wall and a ledge on it"
[[half_plane]]          # the wall: solid at x >= 0
point_m = [0.0, 0.0]
normal = [-1.0, 0.0]
[[polygon]]             # a ledge on the wall, its exposed corner at ({x_edge!r}, {y_top!r})
points_m = [[{x_edge!r}, {y_top - depth!r}], [0.01, {y_top - depth!r}], [0.01, {y_top!r}], [{x_edge!r}, {y_top!r}]]
'''

    front = H.pose(-d_front, 0.5, 90)
    return [
        dict(name="unit_on_ledge_corner", lengths=[0.22, 0.2], front=front, scene=ledge(-0.028, 0.266),
             checks="the hanging unit's back rests on the ledge's corner between two outline corners, "
                    "nothing else touching"),
        dict(name="unit_on_ledge_top", lengths=[0.22, 0.2], front=front, scene=ledge(-0.06, 0.262),
             checks="the hanging unit's back corner rests on the ledge's top, the rear cup's rim on the wall"),
    ]


def solve_case(case, robot, rng):
    log = []
    body = H.Body(robot, case["lengths"])
    scene = H.Scene(case["scene"])
    unit = Unit(robot)
    front = case["front"]
    everything = UnitSet(body, scene, unit, fixed=H.fixed_nodes(body, front))
    t0 = time.time()
    q = H.placed(body, H.unloaded(body, H.pose(0, 0, 90)), front)
    log.append("unloaded shape (g = 0) placed on the front hold")
    q_tc, lam_tc, mu_tc, res_tc, prob = H.load_path(body, q, [1.0], None, front, everything, log)
    t_tc = time.time() - t0
    kick = np.r_[rng.uniform(-1e-3, 1e-3, body.N - 3), 0.0, 0.0, 0.0]
    q_sl, lam_sl, mu_sl, res_sl = prob.slsqp(q_tc + kick)
    q_nw, lam_nw, mu_nw, its, active = prob.polish(q_tc, lam_tc, mu_tc)
    resid = {"trust_constr": prob.kkt_residual(q_tc, lam_tc, mu_tc), "slsqp": prob.kkt_residual(q_sl, lam_sl, mu_sl),
             "newton": prob.kkt_residual(q_nw, lam_nw, mu_nw)}
    agree = {
        "trust_constr_vs_newton": {"q": float(np.max(np.abs(q_tc - q_nw))),
                                   "multipliers": float(np.max(np.abs(np.r_[lam_tc - lam_nw, mu_tc - mu_nw])))},
        "slsqp_vs_newton": {"q": float(np.max(np.abs(q_sl - q_nw))),
                            "multipliers": float(np.max(np.abs(np.r_[lam_sl - lam_nw, mu_sl - mu_nw])))},
    }
    info = dict(residuals=resid, agreement=agree, reduced_hessian_min=prob.reduced_hessian_min(q_nw, lam_nw, mu_nw, active),
                newton_iterations=its, derivative_check=H.check_derivatives(prob, q_nw, rng),
                trust_constr=dict(status=int(res_tc.status), iterations=int(res_tc.nit), seconds=t_tc),
                slsqp=dict(status=int(res_sl.status), iterations=int(res_sl.nit), message=str(res_sl.message)),
                path=log)
    return body, scene, unit, prob, (q_nw, lam_nw, mu_nw, active), info


def record(case, robot, body, scene, unit, prob, sol, info):
    q, lam, mu, active = sol
    W = body.weight()
    front = case["front"]
    out = dict(name=case["name"], checks=case["checks"], discretization=body.disc, lengths_m=case["lengths"],
               elements=body.n, hold="front", front=dict(point_m=[front[0], front[1]], angle_rad=front[2]),
               scene_toml=case["scene"], **H.state_fields(body, q, lam),
               fixed_nodes=sorted([["ab"[c], i] for c, i in H.fixed_nodes(body, front)]))
    out["front_reaction"] = dict(force_n=lam[3:5].tolist(), moment_nm=float(lam[5]))
    contacts = []
    rows = prob.contacts.rows(q, with_hessian=False)
    for i in active:
        info_i = rows[i].info
        if info_i[0] in ("node", "corner"):
            kind, c, j, s, x, n = info_i
            node, frac = (j, 0.0) if kind == "node" else ((j - 1, s) if 0 < s < 1 else (j - 1 + int(s), 0.0))
            contacts.append(dict(chain="ab"[c], node=int(node), fraction=float(frac), point_m=x.tolist(),
                                 normal=n.tolist(), force_n=float(mu[i])))
        else:
            chain, k, s, x, n = info_i
            contacts.append(dict(chain=chain, node=int(k), fraction=float(s), point_m=x.tolist(), normal=n.tolist(),
                                 force_n=float(mu[i])))
    out["contacts"] = contacts
    F, M = np.zeros(2), 0.0
    for at, f, m in [(body.endpoint(q), np.array(out["front_reaction"]["force_n"]), out["front_reaction"]["moment_nm"])] + \
            [(np.array(c["point_m"]), c["force_n"] * np.array(c["normal"]), 0.0) for c in contacts]:
        F += f
        M += m + at[0] * f[1] - at[1] * f[0]
    xg = out["centre_of_mass_m"][0]
    out["balance"] = dict(force_x_rel=float(abs(F[0]) / W), force_y_rel=float(abs(F[1] - W) / W),
                          moment_rel=float(abs(M - xg * W) / (W * 0.3)))
    out["penetration_m"] = float(unit_penetration(body, scene, unit, q))
    out["largest_turn_of_stop"] = near_stop(body, q, robot)
    for key in ("residuals", "agreement", "newton_iterations", "derivative_check", "trust_constr", "slsqp", "path"):
        out[key] = info[key]
    out["reduced_hessian_min"] = info["reduced_hessian_min"]
    out["stable"] = bool(info["reduced_hessian_min"] > 0)
    why = []
    r = out["residuals"]["newton"]
    if max(r["stationarity"], r["equality"]) > 1e-12:
        why.append(f"Newton's residual {r}")
    if out["agreement"]["slsqp_vs_newton"]["q"] > 1e-7:
        why.append(f"SLSQP differs by {out['agreement']['slsqp_vs_newton']['q']:.1e}")
    if not out["stable"]:
        why.append("unstable")
    if any(c["force_n"] <= 0 for c in contacts):
        why.append("a contact force <= 0")
    on_unit = [c for c in contacts if c["chain"] == "unit"]
    if not on_unit:
        why.append("the outline carries nothing")
    if any(not 0 < c["fraction"] < 1 for c in on_unit if c["fraction"] != 0.0):
        why.append("a corner's foot outside its edge")
    if out["penetration_m"] > 1e-12:
        why.append(f"penetration {out['penetration_m']:.1e}")
    if max(out["balance"].values()) > 1e-12:
        why.append(f"balance {out['balance']}")
    if out["largest_turn_of_stop"] >= STOP_FRACTION:
        why.append(f"a joint at {out['largest_turn_of_stop']:.2f} of its stop")
    return out, why


def main(argv):
    only = set(argv[1:])
    rng = np.random.default_rng(31)
    robot = robot_values()
    cases = []
    for case in case_list(robot):
        if only and case["name"] not in only:
            continue
        t0 = time.time()
        body, scene, unit, prob, sol, info = solve_case(case, robot, rng)
        out, why = record(case, robot, body, scene, unit, prob, sol, info)
        out["seconds"] = time.time() - t0
        touching = ", ".join(f"{c['chain']}{c['node']}@{c['fraction']:.3f}:{c['force_n']:.4f}" for c in out["contacts"])
        print(f"{case['name']:24s} {out['seconds']:5.0f} s  newton {max(out['residuals']['newton']['stationarity'], out['residuals']['newton']['equality']):.1e}"
              f"  slsqp-newton {out['agreement']['slsqp_vs_newton']['q']:.1e}  balance {max(out['balance'].values()):.1e}"
              f"  pen {out['penetration_m']:.1e}  stop {out['largest_turn_of_stop']:.2f}  unit {out['unit_point_m']} "
              f"{math.degrees(out['unit_angle_rad']):.2f} deg  contacts {touching}", flush=True)
        if why:
            print(f"  NOT WRITTEN: {'; '.join(why)}")
            continue
        cases.append(out)
    if not cases:
        sys.exit("no case written")
    doc = dict(generator=GENERATOR, versions={"python": sys.version.split()[0], "numpy": np.__version__,
                                              "scipy": scipy.__version__},
               robot=robot, description=__doc__.strip().splitlines()[0], cases=cases)
    OUT.write_text(json.dumps(doc, indent=1) + "\n")
    print(f"wrote {OUT.relative_to(H.ROOT)}: {len(cases)} cases")


if __name__ == "__main__":
    main(sys.argv)
