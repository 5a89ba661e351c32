"""Shared fixtures: the repository, the `leech` command line to compare with."""

import json
import os
import pathlib
import subprocess

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def leech_bin() -> pathlib.Path:
    """The `leech` binary: $LEECH_BIN (CI sets it), else built here with cargo."""
    given = os.environ.get("LEECH_BIN")
    if given:
        return pathlib.Path(given)
    subprocess.run(["cargo", "build", "-q", "-p", "leech-cli"], cwd=ROOT, check=True)
    meta = subprocess.run(
        ["cargo", "metadata", "--format-version", "1", "--no-deps"], cwd=ROOT, check=True, capture_output=True
    )
    return pathlib.Path(json.loads(meta.stdout)["target_directory"]) / "debug" / "leech"


@pytest.fixture(scope="session")
def cli(leech_bin):
    """Runs `leech ARGS --json` (or with `json=False`, as given) and parses its output."""

    def run(*args, json_out=True):
        argv = [str(leech_bin), *map(str, args)] + (["--json"] if json_out else [])
        done = subprocess.run(argv, capture_output=True, text=True, timeout=300, cwd=ROOT)
        assert done.returncode == 0, done.stderr
        return json.loads(done.stdout) if json_out else done.stdout

    return run


def assert_same(a, b, path="", tol=1e-12):
    """Two JSON values equal: the same keys, strings and flags, numbers within `tol`."""
    if isinstance(a, dict):
        assert isinstance(b, dict) and set(a) == set(b), f"{path}: keys {sorted(a)} != {sorted(b)}"
        for k in a:
            assert_same(a[k], b[k], f"{path}.{k}", tol)
    elif isinstance(a, list):
        assert isinstance(b, list) and len(a) == len(b), f"{path}: lengths differ"
        for i, (x, y) in enumerate(zip(a, b)):
            assert_same(x, y, f"{path}[{i}]", tol)
    elif isinstance(a, float) or isinstance(b, float):
        assert abs(a - b) <= tol, f"{path}: {a} != {b}"
    else:
        assert a == b, f"{path}: {a!r} != {b!r}"
