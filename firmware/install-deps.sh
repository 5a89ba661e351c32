#!/bin/sh
# Installs the Debian packages that build the LEeCH firmware (firmware/build.sh) and its simavr
# harness: the AVR compiler and C library, the Arduino core and arduino-mk, and simavr's library.
# Does nothing when they are all installed; uses sudo only when not run as root.
set -eu

packages="gcc-avr avr-libc arduino-core-avr arduino-mk simavr libsimavr-dev libsimavrparts1 libelf-dev"

# `install-deps.sh --list` prints the packages only (for CI, which installs
# them together with its own).
if [ "${1:-}" = "--list" ]; then
    echo "$packages"
    exit 0
fi

missing=""
for p in $packages; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing="$missing $p"
done
if [ -z "$missing" ]; then
    echo "install-deps.sh: all present ($packages)"
    exit 0
fi

sudo=""
[ "$(id -u)" -eq 0 ] || sudo="sudo"
$sudo apt-get update
$sudo apt-get install -y --no-install-recommends $missing
