#!/bin/sh
# Builds the LEeCH Arduino Mega firmware (firmware/leech) into OUTDIR (default: target/firmware
# at the repository root): leech.elf and leech.hex. Prints flash and RAM use with the margin to
# the ATmega2560's 256 KiB flash and 8 KiB RAM, and fails when RAM use (.data + .bss + .noinit,
# the stack not included) exceeds 75 % of the RAM: the other 25 % (2 KiB) is left to the stack.
# When firmware/simavr/Makefile exists, also builds the simulator harness into OUTDIR.
#
#   firmware/build.sh [OUTDIR]
#
# Needs the Debian packages of firmware/install-deps.sh.
set -eu

here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/.." && pwd)
out=${1:-$root/target/firmware}
mkdir -p "$out"
out=$(cd "$out" && pwd)

FLASH_BYTES=262144
RAM_BYTES=8192
RAM_LIMIT_PERCENT=75

make -s -C "$here/leech" OBJDIR="$out/obj" >"$out/build.log" 2>&1 || {
    cat "$out/build.log"
    echo "build.sh: the firmware did not build (log: $out/build.log)" >&2
    exit 1
}
cp "$out/obj/leech.elf" "$out/leech.elf"
cp "$out/obj/leech.hex" "$out/leech.hex"

# Section sizes: flash holds .text and .data's initial values; RAM holds .data, .bss, .noinit.
sizes=$(avr-size -A "$out/leech.elf")
section() { echo "$sizes" | awk -v s="$1" '$1 == s { print $2; exit }'; }
text=$(section .text); data=$(section .data); bss=$(section .bss); noinit=$(section .noinit)
flash=$(( ${text:-0} + ${data:-0} ))
ram=$(( ${data:-0} + ${bss:-0} + ${noinit:-0} ))
echo "leech firmware: $out/leech.hex"
echo "flash: $flash of $FLASH_BYTES bytes ($(( flash * 100 / FLASH_BYTES )) %), $(( FLASH_BYTES - flash )) free (the bootloader takes 8 KiB of the free part)"
echo "RAM:   $ram of $RAM_BYTES bytes ($(( ram * 100 / RAM_BYTES )) %), $(( RAM_BYTES - ram )) left for the stack; limit $RAM_LIMIT_PERCENT %"
if [ $(( ram * 100 )) -gt $(( RAM_BYTES * RAM_LIMIT_PERCENT )) ]; then
    echo "build.sh: static RAM use exceeds $RAM_LIMIT_PERCENT % of the ATmega2560's RAM" >&2
    exit 1
fi

if [ -f "$here/simavr/Makefile" ]; then
    make -C "$here/simavr" OUT="$out"
fi
