"""Same answers: a before/after regression harness for the `leech` CLI.

Runs two `leech` binaries (say, one built before a change and one after it)
on the same corpus of 334 command lines and reports whether they give
the same answers. The corpus, generated here, follows the contact census
(crates/leech/src/stance/census.rs): the built-in robot's rear cup on a floor
(driving unit at 0.25, 0.032 m, clamp direction 0 deg) fed against a wall
(solid at x >= 0.35 m) and a 60 mm step (a block from x = 0.35 m) over the
census's 136 length pairs, plus plain `shape`, `chain` and `shape3d` cases.
The scene files are written into a temporary directory, removed at the end.

Every case runs under both binaries with `--json` (timeout 60 s each). A case
agrees when the exit codes are equal and, if both succeeded, every numeric
JSON leaf under a key ending in `_m` (lengths, points: `points_m`,
`endpoint_m`, ...) or in a point list (a list of number pairs or triples,
such as the constant-curvature model's `chains.a`) agrees to --tolerance-m
(absolute), `_rad` to --tolerance-rad, `_n` to --tolerance-n, and every
string, boolean and list length is equal. Other numbers (iterations, steps,
residuals, energies, moments `_nm`, safety factors, unit normals, timing)
are ignored, and listed as such.

    python3 validation/same_answers.py --before OLD/leech --after target/release/leech \
        [--tolerance-m 1e-9] [--jobs 2] [--out report.json]

Exit status 0 when no case disagrees and none fails under one binary only;
else 1. Cases failing under both are reported but do not fail the run.
"""

import argparse
import json
import math
import shlex
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

TIMEOUT_S = 60
REAR = "0.25,0.032,0"  # the census's driving unit (m) and clamp direction (deg)
TILTED_REAR = "0.2499,0.03203,-0.0674"
AHEAD_M = 0.35  # where the wall or step starts
FLOOR = "[[half_plane]]\npoint_m = [0.0, 0.0]\nnormal = [0.0, 1.0]\n"
# A [start] only for shape3d, which has no --rear: the rear cup (not the
# driving unit) on the floor, 32 mm below the census's driving unit.
START = "[start]\nrear_cup_m = [0.25, 0.0]\ndirection_deg = 0\n"
WALL = f'[[half_plane]]\npoint_m = [{AHEAD_M}, 0.0]\nnormal = [-1.0, 0.0]\n'


def step(height_m):
    x0, x1 = AHEAD_M, AHEAD_M + 1.0  # buried 0.1 m in the floor, as the census's
    return f"[[polygon]]\npoints_m = [[{x0}, -0.1], [{x1}, -0.1], [{x1}, {height_m}], [{x0}, {height_m}]]\n"


SCENES = {
    "wall_ahead.toml": 'name = "wall ahead"\n' + FLOOR + WALL,
    "step_60mm.toml": 'name = "step 60 mm"\n' + FLOOR + step(0.06),
    "wall_ahead_start.toml": 'name = "wall ahead"\n' + START + FLOOR + WALL,
}


def census_lengths():
    """The census's [LA, LB] pairs as strings (m), LB <= 0.30 m: 136 pairs."""
    pairs = []
    for la in range(160, 301, 10):
        for d in (0, 2, 4, 6, 8, 10, 12, 15, 20, 30):
            if la + d <= 300:
                pairs.append(f"{la / 1000:g},{(la + d) / 1000:g}")
    return pairs


def corpus():
    """(group, argv after `leech`) for every case; `@name` is a scene file."""
    cases = []
    grid = census_lengths()
    around = ["--rear", REAR, "--free-cups"]
    for lengths in grid:
        cases.append(("wall, rest", ["shape", "--lengths", lengths, "--scene", "@wall_ahead.toml", *around, "rest"]))
    for lengths in grid[::3]:
        cases.append(("wall, rest, tilted rear", ["shape", "--lengths", lengths, "--scene", "@wall_ahead.toml",
                                                  "--rear", TILTED_REAR, "--free-cups", "rest"]))
    for lengths in grid[::2]:
        cases.append(("step 60 mm, rest", ["shape", "--lengths", lengths, "--scene", "@step_60mm.toml", *around, "rest"]))
    for lengths in grid[::4]:
        cases.append(("step 60 mm, pass-through",
                      ["shape", "--lengths", lengths, "--scene", "@step_60mm.toml", *around, "pass-through"]))
    floor = ["shape", "--lengths", "0.30,0.28", "--scene", "floor"]
    cases.append(("plain shape", floor))
    cases += [("plain shape", floor + ["--shape-parameter", p]) for p in ("100", "300", "1000")]
    cases.append(("plain shape", ["shape", "--lengths", "0.30,0.28", "--model", "both"]))  # no scene with both
    for lengths in ("0.05,0.05", "0.1,0.12", "0.16,0.2", "0.2,0.2", "0.22,0.25",
                    "0.25,0.22", "0.28,0.3", "0.3,0.3", "0.3,0.16", "0.12,0.3"):
        cases.append(("plain shape", ["shape", "--lengths", lengths]))
    cases.append(("plain shape", ["shape", "--lengths", "0.2,0.22", "--model", "both"]))
    for lengths, front, scene in (("0.2,0.2", "0.18,0.03,0", ["--scene", "floor"]),
                                  ("0.2,0.2", "0.19,0.028,0", ["--scene", "floor"]),
                                  ("0.25,0.25", "0.23,0.03,0", ["--scene", "floor"]),
                                  ("0.3,0.3", "0.27,0.03,0", ["--scene", "floor"]),
                                  ("0.2,0.2", "-0.01,0.19,90", []),
                                  ("0.2,0.21", "0.0,0.19,90", [])):
        cases.append(("shape, both cups hold", ["shape", "--lengths", lengths, *scene, "--hold", "both", "--front", front]))
    cases.append(("shape, both cups hold", ["shape", "--lengths", "0.2,0.2", "--hold", "front", "--front", "0.2,0.3,0"]))
    tube = ["chain", "--element-length", "0.01", "--element-mass", "0.001"]
    for extra in (["--elements", "10", "--stiffness", "0.5"], ["--elements", "20", "--stiffness", "0.5"],
                  ["--elements", "30", "--stiffness", "0.5"], ["--elements", "20", "--shape-parameter", "100"],
                  ["--elements", "20", "--stiffness", "0.5", "--base-angle", "90"],
                  ["--elements", "30", "--stiffness", "0.5", "--tip-mass", "0.021"],
                  ["--elements", "20", "--stiffness", "0.5", "--scene", "floor"]):
        cases.append(("chain", tube + extra))
    body3 = [(["0.2,0.2,0.2"], []), (["0.2,0.21,0.22"], []), (["0.25,0.24,0.26"], []), (["0.3,0.28,0.29"], []),
             (["0.16,0.17,0.16"], []), (["0.22,0.22,0.25"], []),
             (["0.2,0.2,0.2"], ["--free-axial-rotation"]), (["0.25,0.22,0.27"], ["--free-axial-rotation"]),
             (["0.2,0.21,0.22"], ["--model", "constant-curvature"]),
             (["0.2,0.2,0.2"], ["--scene", "floor"]), (["0.2,0.21,0.22"], ["--scene", "floor"]),
             (["0.3,0.28,0.28"], ["--scene", "floor"]), (["0.26,0.3,0.27"], ["--scene", "floor"]),
             (["0.2,0.21,0.22"], ["--scene", "@wall_ahead_start.toml"]),
             (["0.25,0.26,0.27"], ["--scene", "@wall_ahead_start.toml"]),
             (["0.28,0.28,0.3"], ["--scene", "@wall_ahead_start.toml"]),
             (["0.2,0.2,0.2"], ["--hold", "both", "--front", "0,0.19,0,90"]),
             (["0.2,0.2,0.2"], ["--hold", "both", "--front", "0,0.19,0.01,90,5"]),
             (["0.2,0.2,0.2"], ["--hold", "front", "--front", "0,0.25,0,90"]),
             (["0.2,0.2,0.2"], ["--hold", "front-pivot", "--front", "0,0.25,0,90"])]
    cases += [("shape3d", ["shape3d", "--lengths", *lengths, *extra]) for lengths, extra in body3]
    return [(group, argv + ["--json"]) for group, argv in cases]


def run(binary, argv, scene_dir):
    """Runs one case: exit code (None on a timeout), stdout, the error line, seconds."""
    args = [str(scene_dir / a[1:]) if a.startswith("@") else a for a in argv]
    started = time.monotonic()
    try:
        done = subprocess.run([binary, *args], capture_output=True, text=True, timeout=TIMEOUT_S)
    except subprocess.TimeoutExpired:
        return {"rc": None, "stdout": "", "error": f"timed out after {TIMEOUT_S} s", "seconds": TIMEOUT_S}
    lines = [line for line in done.stderr.splitlines() if line.strip()]
    error = next((line for line in reversed(lines) if line.startswith("leech")), lines[-1] if lines else "")
    return {"rc": done.returncode, "stdout": done.stdout, "error": error, "seconds": time.monotonic() - started}


def tolerance(key, tol):
    """The tolerance of a numeric leaf under `key`, or None when ignored."""
    for suffix, value in tol.items():
        if key.endswith(suffix):
            return value
    return None


NOT_POINTS = {"plate_frame"}  # lists of number triples that are not points: a rotation matrix


def unit_key(key, value):
    """`key`, or `key_m` for a point list (in m) under a key without a unit, such as
    the constant-curvature model's `chains.a`: a list of number pairs or triples."""
    points = isinstance(value, list) and value and all(
        isinstance(p, list) and len(p) in (2, 3) and all(isinstance(x, (int, float)) for x in p) for p in value)
    return f"{key}_m" if points and key not in NOT_POINTS and not key.endswith(("_m", "_rad", "_n")) else key


def compare(a, b, tol, path="", key="", found=None):
    """Walks two JSON values; returns {"worst": (ratio, diff, path), "ignored": keys, "problems": n}."""
    found = found if found is not None else {"worst": (0.0, 0.0, ""), "ignored": set(), "problems": 0}

    def differ(ratio, diff, where):
        found["problems"] += ratio > 1.0
        if ratio > found["worst"][0]:
            found["worst"] = (ratio, diff, where)

    if isinstance(a, dict) and isinstance(b, dict):
        for k in sorted(set(a) | set(b)):
            if k in a and k in b:
                compare(a[k], b[k], tol, f"{path}/{k}", unit_key(k, a[k]), found)
            elif tolerance(k, tol) is None and not isinstance(a.get(k, b.get(k)), (dict, list)):
                found["ignored"].add(f"{k} (only in {'before' if k in a else 'after'})")
            elif a.get(k, b.get(k)) in ([], {}):
                # A field one side added and left empty says nothing the other does not.
                found["ignored"].add(f"{k} (empty, only in {'before' if k in a else 'after'})")
            else:
                differ(math.inf, math.inf, f"{path}/{k} (only in {'before' if k in a else 'after'})")
    elif isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            differ(math.inf, math.inf, f"{path} (lengths {len(a)} and {len(b)})")
        for i, (x, y) in enumerate(zip(a, b)):
            compare(x, y, tol, f"{path}/{i}", key, found)
    elif all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in (a, b)):
        limit = tolerance(key, tol)
        if limit is None:
            found["ignored"].add(key)
        elif not (math.isnan(a) and math.isnan(b)):
            diff = abs(a - b) if not (math.isnan(a) or math.isnan(b)) else math.inf
            differ(diff / limit if limit > 0 else (math.inf if diff else 0.0), diff, path)
    elif a != b:  # strings, booleans, null against a number, a type change
        differ(math.inf, math.inf, f"{path} ({json.dumps(a)[:40]} and {json.dumps(b)[:40]})")
    return found


def judge(case, before, after, tol):
    """One case's outcome: agree, disagree, both failed or one failed."""
    group, argv = case
    result = {"group": group, "command": "leech " + shlex.join(a.lstrip("@") for a in argv),
              "rc": [before["rc"], after["rc"]], "seconds": [before["seconds"], after["seconds"]]}
    if before["rc"] != 0 or after["rc"] != 0:
        if before["rc"] == 0 or after["rc"] == 0:
            result.update(outcome="one failed", error=before["error"] or after["error"])
        else:
            same = before["error"] == after["error"] and before["rc"] == after["rc"]
            result.update(outcome="both failed", same_error=same, errors=[before["error"], after["error"]])
        return result
    try:
        found = compare(json.loads(before["stdout"]), json.loads(after["stdout"]), tol)
    except json.JSONDecodeError:
        same = before["stdout"] == after["stdout"]
        found = {"worst": (0.0 if same else math.inf, 0.0 if same else math.inf, "(output not JSON)"),
                 "ignored": set(), "problems": int(not same)}
    ratio, diff, where = found["worst"]
    result.update(outcome="disagree" if found["problems"] else "agree",
                  largest_difference=diff if math.isfinite(diff) else "structural",
                  at=where, ignored=sorted(found["ignored"]))
    return result


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--before", required=True, help="the old leech binary")
    parser.add_argument("--after", required=True, help="the new leech binary")
    parser.add_argument("--tolerance-m", type=float, default=1e-9, help="absolute, on `_m` leaves (m)")
    parser.add_argument("--tolerance-rad", type=float, default=1e-9, help="absolute, on `_rad` leaves (rad)")
    parser.add_argument("--tolerance-n", type=float, default=1e-6, help="absolute, on `_n` leaves (N)")
    parser.add_argument("--jobs", type=int, default=2, help="cases run at once")
    parser.add_argument("--out", help="write every case's outcome to this JSON file")
    args = parser.parse_args()
    tol = {"_m": args.tolerance_m, "_rad": args.tolerance_rad, "_n": args.tolerance_n}
    binaries = [str(Path(b).resolve()) for b in (args.before, args.after)]
    cases = corpus()
    started = time.monotonic()
    with tempfile.TemporaryDirectory(prefix="same_answers_") as tmp:
        scene_dir = Path(tmp)
        for name, text in SCENES.items():
            (scene_dir / name).write_text(text)

        def one(case):
            before, after = (run(b, case[1], scene_dir) for b in binaries)
            return judge(case, before, after, tol)

        with ThreadPoolExecutor(max_workers=max(1, args.jobs)) as pool:
            results = list(pool.map(one, cases))
    seconds = time.monotonic() - started

    by = {k: [r for r in results if r["outcome"] == k] for k in ("agree", "disagree", "both failed", "one failed")}
    groups = {}
    for r in results:
        groups.setdefault(r["group"], []).append(r["outcome"])
    print(f"before: {binaries[0]}\nafter:  {binaries[1]}")
    print(f"cases: {len(results)} in {seconds:.1f} s ({args.jobs} jobs)")
    for group, outcomes in groups.items():
        counts = ", ".join(f"{outcomes.count(k)} {k}" for k in by if outcomes.count(k))
        print(f"  {group:28} {len(outcomes):4}: {counts}")
    print(f"agree: {len(by['agree'])}")
    print(f"disagree: {len(by['disagree'])}")
    for r in by["disagree"]:
        diff = r["largest_difference"]
        print(f"  {r['command']}\n    largest difference {diff if isinstance(diff, str) else f'{diff:.3g}'} at {r['at']}")
    same = sum(r["same_error"] for r in by["both failed"])
    print(f"both failed: {len(by['both failed'])} ({same} with the same error, {len(by['both failed']) - same} not)")
    for r in by["both failed"]:
        print(f"  {r['command']}  (exit {r['rc'][0]}, {r['rc'][1]})")
        if r["same_error"]:
            print(f"    both:   {r['errors'][0]}")
        else:
            print(f"    before: {r['errors'][0]}\n    after:  {r['errors'][1]}")
    print(f"one failed: {len(by['one failed'])}")
    for r in by["one failed"]:
        print(f"  {r['command']}  (exit before {r['rc'][0]}, after {r['rc'][1]})\n    {r['error']}")
    ignored = sorted({k for r in results for k in r.get("ignored", [])})
    print(f"ignored (not compared): {', '.join(ignored)}")
    if args.out:
        summary = {k: len(v) for k, v in by.items()}
        report = {"before": binaries[0], "after": binaries[1], "seconds": seconds, "tolerances": tol,
                  "summary": {"cases": len(results), **summary}, "cases": results}
        Path(args.out).write_text(json.dumps(report, indent=1, default=str) + "\n")
    return 0 if not by["disagree"] and not by["one failed"] else 1


if __name__ == "__main__":
    sys.exit(main())
