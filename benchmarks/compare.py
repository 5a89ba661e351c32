#!/usr/bin/env python3
"""Time three ways of finding the static equilibrium of the same LEeCH body, in one run.

1. leech       the Rust solver: `leech shape --lengths LA,LB --repeat N --json` reports the
               in-process median time of N full cold solves (feeding at g = 0, then gravity).
2. MuJoCo      the paper's method: the damped dynamics of the two chains, joined by a weld,
               settled to rest from the unloaded (g = 0) shape with gravity switched on.
3. SciPy       direct constrained minimization of the potential V with the three weld equality
               constraints (trust-constr, analytic derivatives), from the constant-curvature arc
               at full gravity. SLSQP and the validation's loading path are listed for context.

Every engine is checked against leech's equilibrium (endpoint = tip of chain A, as in leech's
`endpoint_m`): a speed ratio means nothing unless the engines found the same shape.

The body is read from `leech robot --json` (the built-in robot unless --robot is given) and built
in Python with the validation's own model code (validation/references.py, written from the model
equations, not from the Rust code), so all three engines solve exactly the same discrete model.

Run from the repository root, after `cargo build --release` (see benchmarks/README.md):

    validation/.venv/bin/python benchmarks/compare.py

Prints a table and writes benchmarks/results.json. Takes about 70 s, nearly all of it the
MuJoCo run (its timestep is 1e-5 s and it needs ~18 s of simulated time to come to rest).
"""

from __future__ import annotations

import os

# All three engines run on one thread (leech and MuJoCo's mj_step are single-threaded; SciPy's
# small dense linear algebra would otherwise use OpenBLAS threads), so the ratios compare
# algorithms, not core counts. Must be set before numpy is imported; an explicit environment wins.
_CALLER_ENV = dict(os.environ)
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse
import datetime
import hashlib
import json
import math
import platform
import statistics
import subprocess
import sys
import time
from pathlib import Path

import mujoco
import numpy as np
import scipy
from scipy import linalg, optimize

ROOT = Path(__file__).resolve().parent.parent
# Reuse the validation's model code (chain/two-chain potential, constraints, MuJoCo XML, damping
# choice) instead of copying it: one model definition for fixtures and benchmark alike.
sys.path.insert(0, str(ROOT / "validation"))
sys.dont_write_bytecode = True  # leave no __pycache__ behind in validation/
import references as ref  # noqa: E402  (needs the sys.path entry above)

ENDPOINT_TOL = 1e-5  # m: the engines must agree with leech's endpoint to this to count as "same shape"


# ----------------------------------------------------------------------------------------------
# Small helpers
# ----------------------------------------------------------------------------------------------


def run_json(cmd):
    """Run a leech command and parse its JSON output (a non-zero exit is an error, not a result)."""
    out = subprocess.run(cmd, capture_output=True, text=True)
    if out.returncode != 0:
        raise SystemExit(f"{' '.join(map(str, cmd))} failed ({out.returncode}): {out.stderr.strip()}")
    return json.loads(out.stdout)


def fmt_time(t):
    if t < 1e-3:
        return f"{t * 1e6:.1f} us"
    if t < 1.0:
        return f"{t * 1e3:.2f} ms"
    return f"{t:.2f} s"


def timed(fn, repeats):
    """Call fn() `repeats` times; return the last result and the median and min wall time (s).
    perf_counter, monotonic and high resolution; the median resists other load on the machine."""
    times, result = [], None
    for _ in range(repeats):
        t0 = time.perf_counter()
        result = fn()
        times.append(time.perf_counter() - t0)
    return result, statistics.median(times), min(times), times


def machine_info():
    """What the numbers were measured on (ratios move with the CPU, absolute times even more)."""
    lscpu = subprocess.run(["lscpu"], capture_output=True, text=True).stdout
    model = next((ln.split(":", 1)[1].strip() for ln in lscpu.splitlines() if ln.startswith("Model name")), "?")
    # nproc honours OMP_NUM_THREADS, which is set to 1 above: ask it with the caller's environment.
    env = {k: v for k, v in os.environ.items() if k != "OMP_NUM_THREADS"}
    if "OMP_NUM_THREADS" in _CALLER_ENV:
        env["OMP_NUM_THREADS"] = _CALLER_ENV["OMP_NUM_THREADS"]
    return {
        "nproc": int(subprocess.run(["nproc"], capture_output=True, text=True, env=env).stdout.strip()),
        "cpu_model": model,
        "platform": platform.platform(),
        "python": platform.python_version(),
        "load_average_1_5_15_min": list(os.getloadavg()),
    }


def git_info():
    """The leech binary is built from the working tree, which may have uncommitted edits."""
    def git(*a):
        return subprocess.run(["git", "-C", str(ROOT), *a], capture_output=True, text=True).stdout
    changed = [ln[3:] for ln in git("status", "--porcelain").splitlines()]  # "XY path": not stripped
    return {"commit": git("rev-parse", "HEAD").strip(),
            "uncommitted_files_outside_benchmarks": sorted(f for f in changed if not f.startswith("benchmarks/"))}


# ----------------------------------------------------------------------------------------------
# The body, from leech's own robot description
# ----------------------------------------------------------------------------------------------


def build_body(robot, LA, LB):
    """The validation's TwoChain for the robot leech uses: chain A (k, m) from the origin, chain B
    (2k, 2m, payload at its tip) from b nu(phi0), tips welded c apart."""
    t, b, w, mdl = robot["tube"], robot["body"], robot["world"], robot["model"]
    tc = ref.TwoChain.make(mdl["discretization"], t["element_length_m"], t["element_mass_kg"],
                           t["joint_stiffness_nm_per_rad"], b["base_spacing_m"], b["tip_spacing_m"],
                           b["payload_kg"], math.radians(w["base_angle_deg"]), LA, LB)
    return tc, w["gravity_m_per_s2"]


def endpoint(tc, q):
    """leech's endpoint_m is the tip of chain A's last link."""
    a, _ = tc.split(q)
    return tc.A.tip(a)


# ----------------------------------------------------------------------------------------------
# 1. leech
# ----------------------------------------------------------------------------------------------


def leech_timing_cmd(leech, robot_args, lengths, repeat):
    return [leech, "shape", *robot_args, "--lengths", lengths, "--repeat", str(repeat), "--json"]


def run_leech(leech, robot_args, lengths, repeat, runs):
    """`runs` invocations of the timing command (main() makes as many again after MuJoCo).

    One invocation times 200 solves in about 10 ms. On the shared 2-core VM this was measured on,
    whole invocations come out either near 46 us or near 62-76 us per solve (bursts lasting
    seconds, seen with nothing else running; up to 118 us with two cargo builds), while the
    Python engines, running for seconds, average over such bursts. So leech is sampled at the
    start and at the end of the script, and the figure is the median of all run medians; the
    best run median (the undisturbed cost) is kept beside it."""
    cmd = leech_timing_cmd(leech, robot_args, lengths, repeat)
    results = [run_json(cmd) for _ in range(runs)]
    res = results[-1]
    res["solve_time_s_runs"] = [r["solve_time_s"] for r in results]
    # For context only: one whole `leech shape` process (startup, parsing, one solve, JSON output).
    one = [leech, "shape", *robot_args, "--lengths", lengths, "--json"]
    _, proc_median, _, _ = timed(lambda: subprocess.run(one, capture_output=True, check=True), 20)
    return res, cmd, proc_median


# ----------------------------------------------------------------------------------------------
# 3. SciPy (run before MuJoCo: MuJoCo's damping is chosen from the SciPy equilibrium)
# ----------------------------------------------------------------------------------------------


def scipy_trust_constr(tc, g, q0):
    """trust-constr on V with the weld constraints C(q) = 0, with every analytic derivative SciPy
    can use (gradient, Hessian, constraint Jacobian and constraint Hessians): SciPy's best case.
    Same options as the validation's TwoChain.minimize, without its Newton polish (timed apart)."""
    con = optimize.NonlinearConstraint(tc.cons, 0.0, 0.0, jac=tc.cons_jac, hess=lambda q, v: tc.cons_hess(q, v))
    return optimize.minimize(lambda q: tc.potential(q, g), q0, jac=lambda q: tc.grad(q, g),
                             hess=lambda q: tc.hess(q, g), method="trust-constr", constraints=[con],
                             options={"gtol": 1e-11 * tc.A.k, "xtol": 1e-14, "maxiter": 5000})


def scipy_slsqp(tc, g, q0):
    """SLSQP: the other common constrained minimizer (gradients only, quasi-Newton Hessian)."""
    return optimize.minimize(lambda q: tc.potential(q, g), q0, jac=lambda q: tc.grad(q, g), method="SLSQP",
                             constraints=[{"type": "eq", "fun": tc.cons, "jac": tc.cons_jac}],
                             options={"ftol": 1e-16, "maxiter": 5000})


def kkt_residual(tc, q, g):
    """The validation's scaled KKT residual (stationarity / k, weld / l, parallel in rad) with the
    least-squares multipliers: how far an optimizer's answer is from an exact equilibrium."""
    lam = np.linalg.lstsq(tc.cons_jac(q).T, tc.grad(q, g), rcond=None)[0]
    return float(np.max(np.abs(tc.kkt_residual(q, lam, g))))


# ----------------------------------------------------------------------------------------------
# 2. MuJoCo (adapter: the validation builds the weld model inline in run_two, so the same steps
#    are wrapped here as functions, calling references.py for everything that is a function there)
# ----------------------------------------------------------------------------------------------


def mujoco_setup(tc, g, q_unloaded, q_eq, lam_eq):
    """Damping and timestep exactly as validation/references.py run_two chooses them (it does this
    inline, so these lines mirror it; keep them in step when run_two changes).

    Damping: ~0.3 of critical in the lowest mode of the linearization at the equilibrium (less if
    an overdamped mode would then settle more slowly).
    Timestep: min(1e-5 s, 0.5 / omega_max): the weld is soft, its violation at rest scales with
    dt^2, and 1e-5 s keeps it near 1e-8 m. Returns the MuJoCo weld spec and these choices.
    This setup uses the (SciPy) equilibrium, which a real user of MuJoCo would have to guess; it is
    not timed, so it only helps MuJoCo."""
    nA, nB = tc.A.n, tc.B.n
    a0, b0 = tc.split(q_unloaded)
    relpos = (tc.A.lengths[-1] - tc.B.lengths[-1], 0.0, -tc.c)  # B's last frame in A's last frame
    weld = ("a%d" % nA, "b%d" % nB, relpos)
    a, b = tc.split(q_eq)
    probe = ref.mujoco_model([("a", tc.A), ("b", tc.B)], [a0, b0], [0.0, 0.0], g, 5e-5, weld)
    data = mujoco.MjData(probe)
    mujoco.mj_forward(probe, data)
    weld_err0 = float(np.max(np.abs(data.efc_pos)))
    assert weld_err0 < 1e-10, f"the unloaded start must satisfy the weld, violation {weld_err0}"
    data.qpos[:] = np.concatenate([tc.A.rel(a) - tc.A.rel(a0), tc.B.rel(b) - tc.B.rel(b0)])
    mujoco.mj_forward(probe, data)
    M = np.zeros((probe.nv, probe.nv))
    mujoco.mj_fullM(probe, data, M)
    S = linalg.block_diag(np.tril(np.ones((nA, nA))), np.tril(np.ones((nB, nB))))  # dphi/dq (relative)
    HL = tc.hess(q_eq, g) - tc.cons_hess(q_eq, lam_eq)
    Z = linalg.null_space(tc.cons_jac(q_eq) @ S)
    # dampers d_j on A and 2 d_j on B, like the springs (damp_ratio > 1 only for a short last element)
    Dhat = np.diag(np.concatenate([tc.A.damp_ratio, 2 * tc.B.damp_ratio]))
    d, zeta1, wmax, rate = ref.choose_damping(M, S.T @ HL @ S, Dhat, Z)
    dt = min(1e-5, 0.5 / wmax)
    return dict(weld=weld, a0=a0, b0=b0, damping=d, zeta1=zeta1, omega_max=wmax, rate=rate, dt=dt)


def mujoco_settle(model, data, rate, tip_of, target, settle=1e-12):
    """Run to rest with the validation's criterion (references.run_to_rest): chunks of one slowest
    decay time 1/rate, stop when no joint angle moved more than `settle` rad over a chunk (or at
    min(60 s, 60/rate) simulated). Mirrored here rather than called because it also records, after
    every chunk, when the endpoint was first within ENDPOINT_TOL of leech's and stayed there: the
    time a user content with 1e-5 m would need (only known afterwards, hence for context only)."""
    assert not model.opt.enableflags & mujoco.mjtEnableBit.mjENBL_SLEEP
    chunk = max(1, int(round(1.0 / rate / model.opt.timestep)))
    max_time = min(60.0, 60.0 / rate)
    t0 = time.perf_counter()
    within_since = None  # (wall, simulated) when the endpoint entered the tolerance for good
    while True:
        q = data.qpos.copy()
        mujoco.mj_step(model, data, nstep=chunk)
        wall = time.perf_counter() - t0
        if not np.all(np.isfinite(data.qpos)):
            break
        mujoco.mj_kinematics(model, data)  # frames of the current qpos (cheap, once per ~66k steps)
        if np.max(np.abs(tip_of(data) - target)) < ENDPOINT_TOL:
            within_since = within_since or (wall, data.time)
        else:
            within_since = None
        if np.max(np.abs(data.qpos - q)) < settle or data.time > max_time:
            break
    wall = time.perf_counter() - t0
    mujoco.mj_forward(model, data)
    return wall, data.time, within_since


def run_mujoco(tc, g, setup, target):
    nA = tc.A.n
    # Timed: XML generation + compile (references.mujoco_model) + MjData allocation.
    t0 = time.perf_counter()
    model = ref.mujoco_model([("a", tc.A), ("b", tc.B)], [setup["a0"], setup["b0"]],
                             [setup["damping"], 2 * setup["damping"]], g, setup["dt"], setup["weld"])
    data = mujoco.MjData(model)
    compile_s = time.perf_counter() - t0
    last = model.body("a%d" % nA).id

    def tip_of(d):  # tip of A's last link; the model plane is MuJoCo's x-z plane
        p = d.xpos[last] + tc.A.lengths[-1] * d.xmat[last].reshape(3, 3)[:, 0]
        return np.array([p[0], p[2]])

    sim_s, t_sim, within = mujoco_settle(model, data, setup["rate"], tip_of, target)
    q = np.concatenate([setup["a0"] + np.cumsum(data.qpos[:nA]), setup["b0"] + np.cumsum(data.qpos[nA:])])
    return dict(compile_s=compile_s, sim_s=sim_s, t_sim=t_sim, steps=int(round(t_sim / setup["dt"])),
                within=within, q=q, tip=tip_of(data), weld_violation=float(np.max(np.abs(data.efc_pos))))


# ----------------------------------------------------------------------------------------------
# Main
# ----------------------------------------------------------------------------------------------


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--lengths", default="0.30,0.28", help="LA,LB in m (default: the benchmark case 0.30,0.28)")
    ap.add_argument("--robot", help="robot TOML file (default: leech's built-in robot)")
    ap.add_argument("--leech", default=str(ROOT / "target" / "release" / "leech"), help="leech binary")
    ap.add_argument("--repeat", type=int, default=200, help="cold solves timed inside leech")
    ap.add_argument("--leech-runs", type=int, default=5,
                    help="invocations of the leech timing command, at the start and again at the end")
    ap.add_argument("--scipy-repeats", type=int, default=5, help="timed runs of each SciPy minimizer")
    ap.add_argument("--no-mujoco", action="store_true", help="skip the (~1.5 min) MuJoCo run")
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "results.json"))
    args = ap.parse_args()
    if not Path(args.leech).is_file():
        raise SystemExit(f"{args.leech} not found: run `cargo build --release` first")
    robot_args = ["--robot", args.robot] if args.robot else []
    LA, LB = (float(x) for x in args.lengths.split(","))
    info = {"machine": machine_info(), "git": git_info(),
            "leech_binary": {"path": os.path.relpath(args.leech, ROOT), "sha256": hashlib.sha256(Path(args.leech).read_bytes()).hexdigest(),
                             "modified": datetime.datetime.fromtimestamp(Path(args.leech).stat().st_mtime).isoformat()},
            "versions": {"numpy": np.__version__, "scipy": scipy.__version__, "mujoco": mujoco.__version__},
            "date": datetime.datetime.now().isoformat(timespec="seconds")}

    load = info["machine"]["load_average_1_5_15_min"][0]
    if load > 0.5 * info["machine"]["nproc"]:
        # Other work on the machine (e.g. a cargo build) slows the Python engines and leech alike,
        # but not by the same factor: the ratios are only meaningful on an otherwise idle machine.
        print(f"warning: 1-minute load average {load:.2f} on {info['machine']['nproc']} cores: "
              "timings will be noisy, rerun when the machine is idle", file=sys.stderr)

    robot = run_json([args.leech, "robot", *robot_args, "--json"])
    tc, g = build_body(robot, LA, LB)
    print(f"robot: {robot['name']}; LA = {LA} m, LB = {LB} m -> {tc.A.n} + {tc.B.n} links, "
          f"discretization {robot['model']['discretization']}, g = {g}")

    # 1. leech ----------------------------------------------------------------------------------
    print(f"leech: {args.leech_runs} x {args.repeat} cold solves ...", flush=True)
    lres, lcmd, leech_proc_s = run_leech(args.leech, robot_args, args.lengths, args.repeat, args.leech_runs)
    assert lres["links"] == [tc.A.n, tc.B.n], (lres["links"], tc.A.n, tc.B.n)  # same discretization
    q_leech = np.concatenate([lres["chains"]["a"]["angles_rad"], lres["chains"]["b"]["angles_rad"]])
    ep_leech = np.array(lres["endpoint_m"])
    leech_s = statistics.median(r["median"] for r in lres["solve_time_s_runs"])  # updated at the end
    # Sanity: leech's angles are an equilibrium of the Python model, with leech's endpoint.
    leech_kkt = kkt_residual(tc, q_leech, g)
    assert np.max(np.abs(endpoint(tc, q_leech) - ep_leech)) < 1e-12
    assert leech_kkt < 1e-9, f"leech's shape is not an equilibrium of the validation model ({leech_kkt})"

    def diffs(q, tip=None):
        tip = endpoint(tc, q) if tip is None else tip
        return float(np.max(np.abs(tip - ep_leech))), float(np.max(np.abs(q - q_leech)))

    rows = [dict(method="leech (Rust, Newton + continuation)", key="leech", wall_time_s=leech_s,
                 endpoint_diff_m=0.0, max_angle_diff_rad=0.0, note="")]  # time and note set at the end

    # 3. SciPy ----------------------------------------------------------------------------------
    print(f"SciPy: trust-constr and SLSQP x {args.scipy_repeats}, validation path x 1 ...", flush=True)
    arc = tc.arc()
    r_tc, tc_med, tc_min, _ = timed(lambda: scipy_trust_constr(tc, g, arc), args.scipy_repeats)
    (q_pol, lam_pol, res_pol), pol_s, _, _ = timed(lambda: tc.kkt_polish(r_tc.x, g), args.scipy_repeats)
    r_sl, sl_med, _, _ = timed(lambda: scipy_slsqp(tc, g, arc), args.scipy_repeats)
    # The validation's route (g = 0 from the arc, gravity in 20 steps, each trust-constr + Newton
    # polish): the history-following path, for when the direct solve would pick another branch.
    (q_unl_path, q_path, *_), path_s, _, _ = timed(lambda: ref.solve_two(tc, g), 1)
    ep_d, an_d = diffs(r_tc.x)
    rows.append(dict(method="SciPy trust-constr from arc at full g", key="scipy_trust_constr", wall_time_s=tc_med,
                     endpoint_diff_m=ep_d, max_angle_diff_rad=an_d,
                     note=f"median of {args.scipy_repeats}, {r_tc.nit} iterations, KKT residual "
                          f"{kkt_residual(tc, r_tc.x, g):.0e} (+{fmt_time(pol_s)} Newton polish -> "
                          f"{res_pol:.0e}, endpoint diff {diffs(q_pol)[0]:.0e} m)"))
    ep_d, an_d = diffs(r_sl.x)
    rows.append(dict(method="SciPy SLSQP from arc at full g", key="scipy_slsqp", wall_time_s=sl_med,
                     endpoint_diff_m=ep_d, max_angle_diff_rad=an_d,
                     note=f"median of {args.scipy_repeats}, {r_sl.nit} iterations, KKT residual "
                          f"{kkt_residual(tc, r_sl.x, g):.0e}"))
    ep_d, an_d = diffs(q_path)
    rows.append(dict(method="SciPy validation path (g=0, 20 g-steps)", key="scipy_validation_path",
                     wall_time_s=path_s, endpoint_diff_m=ep_d, max_angle_diff_rad=an_d,
                     note="21 trust-constr solves, each Newton-polished (validation/references.py solve_two)"))

    # 2. MuJoCo ---------------------------------------------------------------------------------
    mj = None
    if not args.no_mujoco:
        # Start: the unloaded (g = 0) equilibrium, from the validation path above (SciPy from the arc).
        # leech reaches its unloaded shape by feeding the tubes from equal lengths; check both agree,
        # so that MuJoCo starts from the robot's own unloaded state.
        l0 = run_json([args.leech, "shape", *robot_args, "--lengths", args.lengths, "--gravity", "0", "--json"])
        unloaded_diff = float(np.max(np.abs(endpoint(tc, q_unl_path) - np.array(l0["endpoint_m"]))))
        assert unloaded_diff < 1e-7, f"SciPy's and leech's unloaded shapes differ by {unloaded_diff} m"
        setup = mujoco_setup(tc, g, q_unl_path, q_pol, lam_pol)
        print(f"MuJoCo: damping {setup['damping']:.4g} N m s/rad (zeta_1 = {setup['zeta1']:.2f}), "
              f"dt = {setup['dt']:.0e} s, settling (about 1.5 min) ...", flush=True)
        mj = run_mujoco(tc, g, setup, ep_leech)
        ep_d, an_d = diffs(mj["q"], mj["tip"])
        within = mj["within"]
        rows.append(dict(method="MuJoCo settle to rest (simulation)", key="mujoco", wall_time_s=mj["sim_s"],
                         endpoint_diff_m=ep_d, max_angle_diff_rad=an_d,
                         note=f"{mj['steps']} steps of {setup['dt']:.0e} s = {mj['t_sim']:.2f} s simulated; "
                              f"compile {fmt_time(mj['compile_s'])} (not in the ratio); within {ENDPOINT_TOL:.0e} m "
                              + (f"of leech after {within[0]:.1f} s wall ({within[1]:.2f} s simulated)" if within
                                 else "never")))
        mj_record = {k: v for k, v in setup.items() if k not in ("weld", "a0", "b0")}
        mj_record = {"damping_nms_per_rad_chain_a": mj_record["damping"], "damping_ratio_lowest_mode": mj_record["zeta1"],
                     "omega_max_rad_per_s": mj_record["omega_max"], "slowest_decay_rate_per_s": mj_record["rate"],
                     "timestep_s": mj_record["dt"], "compile_time_s": mj["compile_s"], "simulation_time_s": mj["sim_s"],
                     "simulated_time_s": mj["t_sim"], "steps": mj["steps"],
                     "wall_time_to_within_tol_s": within[0] if within else None,
                     "simulated_time_to_within_tol_s": within[1] if within else None,
                     "weld_violation_at_rest_m": mj["weld_violation"],
                     "start_unloaded_endpoint_diff_scipy_vs_leech_m": unloaded_diff,
                     "rest_criterion": "max joint-angle change over one slowest decay time < 1e-12 rad"}

    # leech again, after the other engines (see run_leech) -------------------------------------
    cmd = leech_timing_cmd(args.leech, robot_args, args.lengths, args.repeat)
    lres["solve_time_s_runs"] += [run_json(cmd)["solve_time_s"] for _ in range(args.leech_runs)]
    run_medians = [r["median"] for r in lres["solve_time_s_runs"]]
    leech_s, leech_best = statistics.median(run_medians), min(run_medians)
    rows[0]["wall_time_s"] = leech_s
    rows[0]["note"] = (f"median over {len(run_medians)} runs ({args.leech_runs} at the start, {args.leech_runs} at "
                       f"the end) of the in-process median of {lres['solve_time_s']['solves']} cold solves; "
                       f"run medians {', '.join(f'{t * 1e6:.1f}' for t in run_medians)} us; best "
                       f"{fmt_time(leech_best)}; {lres['iterations']} Newton iterations, KKT residual "
                       f"{lres['residual']:.0e}")

    # Table -------------------------------------------------------------------------------------
    for r in rows:
        r["ratio_to_leech"] = r["wall_time_s"] / leech_s
        r["ratio_to_leech_best_run"] = r["wall_time_s"] / leech_best
        r["agrees"] = r["endpoint_diff_m"] < ENDPOINT_TOL
    print(f"\n{'method':42s} {'wall time':>10s} {'x leech':>10s} {'endpoint diff (m)':>17s}  agrees")
    for r in rows:
        print(f"{r['method']:42s} {fmt_time(r['wall_time_s']):>10s} {r['ratio_to_leech']:10.3g} "
              f"{r['endpoint_diff_m']:17.1e}  {'yes' if r['agrees'] else 'NO'}")
    print("\nnotes:")
    for r in rows:
        print(f"  {r['key']}: {r['note']}")
    print(f"  leech whole process (startup + 1 solve + JSON), median of 20: {fmt_time(leech_proc_s)}")
    print(f"  against leech's best run ({fmt_time(leech_best)}) the ratios are "
          + ", ".join(f"{r['key']} {r['ratio_to_leech_best_run']:.3g}" for r in rows[1:]))
    m = info["machine"]
    print(f"\nmachine: {m['cpu_model']}, nproc {m['nproc']}, load average at start {m['load_average_1_5_15_min']}; "
          f"numpy {np.__version__}, scipy {scipy.__version__}, mujoco {mujoco.__version__}, single-threaded BLAS")

    info["machine"]["load_average_at_end_1_5_15_min"] = list(os.getloadavg())
    out = {
        "command": "validation/.venv/bin/python benchmarks/compare.py " + " ".join(sys.argv[1:]),
        **info,
        "case": {"robot": robot, "lengths_m": [LA, LB], "links": [tc.A.n, tc.B.n]},
        "leech": {"command": " ".join(os.path.relpath(str(c), ROOT) if str(c).startswith(str(ROOT)) else str(c) for c in lcmd), "runs": args.leech_runs,
                  "solve_time_s_median_of_runs": leech_s, "solve_time_s_best_run_median": leech_best,
                  "solve_time_s_per_run": lres["solve_time_s_runs"],
                  "iterations": lres["iterations"], "residual": lres["residual"], "endpoint_m": list(ep_leech),
                  "kkt_residual_in_python_model": leech_kkt, "whole_process_median_s": leech_proc_s},
        "scipy": {"trust_constr_median_s": tc_med, "trust_constr_min_s": tc_min, "trust_constr_iterations": int(r_tc.nit),
                  "newton_polish_median_s": pol_s, "polished_kkt_residual": res_pol,
                  "polished_endpoint_diff_m": diffs(q_pol)[0], "slsqp_iterations": int(r_sl.nit),
                  "repeats": args.scipy_repeats, "blas_threads": os.environ.get("OPENBLAS_NUM_THREADS")},
        "mujoco": mj_record if mj else None,
        "endpoint_tolerance_m": ENDPOINT_TOL,
        "rows": [{k: v for k, v in r.items()} for r in rows],
    }
    Path(args.out).write_text(json.dumps(out, indent=1) + "\n")
    print(f"wrote {Path(args.out).relative_to(ROOT) if Path(args.out).is_relative_to(ROOT) else args.out}")
    if not all(r["agrees"] for r in rows):
        raise SystemExit("some engine did not find leech's equilibrium (see endpoint diff)")


if __name__ == "__main__":
    main()
