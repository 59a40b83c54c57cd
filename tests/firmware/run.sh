#!/usr/bin/env bash
# The reader on a Cortex-M4F under QEMU (firmware/cortex-m4f): for a version-3, a version-4
# and a version-5 (sampling shells) conformance vector, builds the `queries` firmware with the
# vector in flash and the eyes of its dump's `query` lines, runs it on QEMU's netduinoplus2
# (STM32F405) with semihosting, and compares every answer with the dump's `query` lines: the
# firmware is a full reader (the library with feature `shells`), so eyes inside the sampling
# sphere are answered from the shells, with their band and both shells' views. Then reports
# the reader's flash (the `size_probe` firmware less `size_base`) and the RAM the queries used
# (stack high-water, scratch row included). Used by .ci/run; needs qemu-system-arm and the
# thumbv7em-none-eabihf Rust target.
#
#   tests/firmware/run.sh [FILE.pvis]   # also report flash and RAM for FILE (no dump check)
#
# FILE's eyes lie around the origin, from 1,000 units away to the origin itself, so that a model
# near the origin (the bundled bunny, `patchvis bake assets/bunny.ply`) is queried in every band;
# the report lists the bands they fell in.
#
# Fails when an answer differs from the dump or when the reader takes more than 18,000 bytes
# of flash or the queries more than 4,096 bytes of RAM.
set -euo pipefail
cd "$(dirname "$0")/../.."
root=$(pwd)
fw=firmware/cortex-m4f
bin=${CARGO_TARGET_DIR:-$root/$fw/target}/thumbv7em-none-eabihf/release
work=${CARGO_TARGET_DIR:-$root/target}/firmware
mkdir -p "$work"

qemu() {
    timeout 120 qemu-system-arm -machine netduinoplus2 -nographic \
        -semihosting-config enable=on,target=native -kernel "$1"
}

# Builds the firmware for $1 (.pvis) with the eyes in $2.
build() {
    (cd "$fw" && PATCHVIS_FIRMWARE_FILE="$1" PATCHVIS_FIRMWARE_EYES="$2" \
        cargo build --quiet --release)
}

flash() {
    size -A "$1" | awk '/^\.text|^\.rodata/ { s += $2 } END { print s }'
}

# Flash of the reader and RAM of the queries for $1; fails (sets `fail`) past the targets:
# 18,000 bytes of flash, 4,096 bytes of RAM.
report() {
    local probe base reader ram
    probe=$(flash "$bin/size_probe")
    base=$(flash "$bin/size_base")
    reader=$((probe - base))
    ram=$(sed -n 's/^ram: stack high-water \([0-9]*\) bytes.*/\1/p' "$work/out.txt")
    echo "$(basename "$1"): reader flash $reader bytes (.text + .rodata, size_probe $probe - size_base $base); $(grep '^ram:' "$work/out.txt")"
    if [[ $reader -gt 18000 || -z $ram || $ram -gt 4096 ]]; then
        echo "FAIL $(basename "$1"): over the targets of 18,000 bytes of flash and 4,096 of RAM"
        fail=1
    fi
}

fail=0
for vector in tests/conformance/valid/010-level3-300-patches-facing.pvis \
              tests/conformance/valid/016-v4-level3-300-patches-facing.pvis \
              tests/conformance/valid/018-v5-level3-300-patches-three-shells-mixed-levels.pvis; do
    dump="${vector%.pvis}.dump"
    sed -n 's/^query \([^ ]*\) .*/\1/p' "$dump" > "$work/eyes.txt"
    build "$root/$vector" "$work/eyes.txt"
    if ! qemu "$bin/queries" > "$work/out.txt" 2>&1; then
        echo "FAIL $vector: the firmware failed"; cat "$work/out.txt"; fail=1; continue
    fi
    if ! diff <(grep '^query ' "$dump") <(grep '^query ' "$work/out.txt") > "$work/diff.txt"; then
        echo "FAIL $vector:"; head -20 "$work/diff.txt"; fail=1; continue
    fi
    echo "ok $vector: $(grep -c '^query ' "$work/out.txt") queries as in the dump"
    report "$vector"
done

if [[ $# -ge 1 ]]; then
    printf '%s\n' 1000,0,0 0,-1000,0 0,0,1000 -700,700,0 300,-400,500 120,0,0 0,70,0 \
        0,0,70 50,-50,0 0,45,20 -20,0,40 10,10,30 5,0,20 0,0,0 > "$work/eyes.txt"
    build "$(realpath "$1")" "$work/eyes.txt"
    qemu "$bin/queries" > "$work/out.txt" 2>&1 || { cat "$work/out.txt"; exit 1; }
    bands=$(sed -n 's/^query .* band \([0-9]*\) .*/\1/p' "$work/out.txt" | sort -n | uniq -c |
        awk '{ printf "%s%s in band %s", sep, $1, $2; sep = ", " }')
    echo "$(basename "$1"): $(grep -c '^query ' "$work/out.txt") eyes${bands:+ ($bands)}"
    report "$1"
fi
exit $fail
