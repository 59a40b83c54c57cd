#!/usr/bin/env bash
# The reader on a Cortex-M4F under QEMU (firmware/cortex-m4f): for a version-3, a version-4, a
# version-5 (sampling shells) and every version-6 (far band) conformance vector, builds the
# `queries` firmware with the vector in flash and the eyes of its dump's `query` lines, runs it
# on QEMU's netduinoplus2 (STM32F405) with semihosting, and compares every answer with the
# dump's `query` lines: the firmware is a full reader (the library with feature `shells`), so
# every eye is answered from the shells around it, with its band and both shells' views. Then
# a small version-6 bake of the bundled bunny (far shells at 2 and 256 sampling distances,
# two nearer the model) is queried in every band, from 1,000 sampling distances out to its
# centre, against `patchvis query` (a debug build of the binary). Reports the reader's flash
# (the `size_probe` firmware less `size_base`) and the RAM the queries used (stack high-water,
# scratch row included). Used by .ci/run; needs qemu-system-arm, the thumbv7em-none-eabihf
# Rust target and cargo.
#
#   tests/firmware/run.sh [FILE.pvis]   # also FILE, in every band, with its flash and RAM
#
# Fails when an answer differs from the dump or from `patchvis query`, when a bake's eyes miss
# a band, or when the reader takes more than 18,000 bytes of flash or the queries more than
# 4,096 bytes of RAM.
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

# Eyes in every band of the shells of the file whose `patchvis info` is on stdin (the sampling
# sphere and the SHEL records), 3 directions at each distance: 1,000 and 10 sampling distances
# D and 1.5 times the outermost shell's, between each two shells (their geometric mean), D
# itself, 0.9 and 0.5 times the innermost shell's; then the centre.
band_eyes() {
    awk '
        /^  centre \[/ { gsub(/[][,]/, " "); cx = $2; cy = $3; cz = $4; D = $NF; d[n++] = D }
        /^    shell [0-9]+: distance / { d[n++] = $4 }
        END {
            for (i = 0; i < n; i++)
                for (j = i + 1; j < n; j++) if (d[j] > d[i]) { t = d[i]; d[i] = d[j]; d[j] = t }
            r[m++] = 1000 * D; r[m++] = 10 * D; r[m++] = 1.5 * d[0]
            for (i = 1; i < n; i++) r[m++] = sqrt(d[i - 1] * d[i])
            r[m++] = D; r[m++] = 0.9 * d[n - 1]; r[m++] = 0.5 * d[n - 1]
            split("0.36 0.48 0.8 -0.6 0.64 -0.48 0 -0.6 0.8", u, " ")
            for (i = 0; i < m; i++)
                for (k = 0; k < 3; k++)
                    printf "%.9g,%.9g,%.9g\n", cx + r[i] * u[3 * k + 1], cy + r[i] * u[3 * k + 2],
                        cz + r[i] * u[3 * k + 3]
            printf "%.9g,%.9g,%.9g\n", cx, cy, cz
        }'
}

# A field of `patchvis query --json`'s one line ($json): a number, true/false or a list.
field() { sed -n "s/.*\"$1\":\(\[[^]]*\]\|[a-z0-9]*\).*/\1/p" <<< "$json"; }

# Runs the firmware on $1 in every band of its shells and compares each answer with
# `patchvis query`; fails (sets `fail`) on a difference or a band without an eye.
check_bands() {
    local info line eye expected shells sampling
    local -A bands=()
    info=$("$patchvis" info "$1")
    shells=$(grep -c '^    shell [0-9]*: distance ' <<< "$info" || true)
    sampling=$(sed -n 's/.*the sampling sphere is shell \([0-9]*\).*/\1/p' <<< "$info")
    band_eyes <<< "$info" > "$work/eyes.txt"
    build "$(realpath "$1")" "$work/eyes.txt"
    if ! qemu "$bin/queries" > "$work/out.txt" 2>&1; then
        echo "FAIL $1: the firmware failed"; cat "$work/out.txt"; fail=1; return
    fi
    while read -r line; do
        eye=$(cut -d' ' -f2 <<< "$line")
        json=$("$patchvis" query "$1" --from "$eye" --json)
        expected="query $eye -> inside $(field inside_sphere) band $(field band) shells $(field shells)"
        expected+=" views $(field views) inner $(field inner_views) patches $(field patches)"
        if [[ "$line" != "$expected" ]]; then
            echo "FAIL $1 from $eye: firmware $line"; echo "     patchvis query $expected"; fail=1
        fi
        bands[$(field band)]=$((${bands[$(field band)]:-0} + 1))
    done < <(grep '^query ' "$work/out.txt")
    echo "ok $(basename "$1"): $(grep -c '^query ' "$work/out.txt") eyes as patchvis query" \
        "answers them ($(for b in $(printf '%s\n' "${!bands[@]}" | sort -n); do
            printf '%s in band %s, ' "${bands[$b]}" "$b"; done)the sampling sphere is shell" \
        "${sampling:-0} of 0..$shells)"
    if [[ ${#bands[@]} -ne $((shells + 2)) ]]; then
        echo "FAIL $1: ${#bands[@]} of its $((shells + 2)) bands queried"; fail=1
    fi
}

cargo build --quiet --bin patchvis
patchvis=${CARGO_TARGET_DIR:-$root/target}/debug/patchvis

fail=0
mapfile -t far_vectors < <(grep -l '^version: 6$' tests/conformance/valid/*.dump | sed 's/\.dump$/.pvis/')
for vector in tests/conformance/valid/010-level3-300-patches-facing.pvis \
              tests/conformance/valid/016-v4-level3-300-patches-facing.pvis \
              tests/conformance/valid/018-v5-level3-300-patches-three-shells-mixed-levels.pvis \
              "${far_vectors[@]}"; do
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

# A version-6 bake: the default shells, far and near, in a quick bake of the bunny.
"$patchvis" bake assets/bunny.ply -o "$work/far.pvis" --level 2 --resolution 128 --patches 200 \
    --quiet
check_bands "$work/far.pvis"
report "$work/far.pvis"

if [[ $# -ge 1 ]]; then
    check_bands "$1"
    report "$1"
fi
exit $fail
