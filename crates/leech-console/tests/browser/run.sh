#!/usr/bin/env bash
# The console's browser tests: builds leech, installs playwright-core from
# the lock file (no browser download: Debian's Chromium drives the page),
# and runs console.test.mjs against `leech serve` on the simulated robot.
# SHOTS (default: target/console-shots) receives the screenshots and
# measurements.json.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
root="$(cd "$here/../../../.." && pwd)"
cd "$root"
if ! command -v chromium > /dev/null; then
    # Debian's Chromium (a test tool's own browser download is not allowed).
    sudo=""
    [ "$(id -u)" -eq 0 ] || sudo="sudo"
    $sudo apt-get update > /dev/null
    $sudo apt-get install -y --no-install-recommends chromium > /dev/null
fi
cargo build -p leech-cli
target="${CARGO_TARGET_DIR:-$root/target}"
export LEECH_BIN="$target/debug/leech"
export SHOTS="${SHOTS:-$target/console-shots}"
export CHROMIUM="${CHROMIUM:-$(command -v chromium)}"
cd "$here"
npm ci --no-audit --no-fund --silent
node --test --test-concurrency=1 console.test.mjs
