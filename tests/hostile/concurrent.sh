#!/usr/bin/env bash
# Two commands naming the same outputs, run N times: a bake of the bunny into OUT.pvis with
# --mesh-out OUT.ply runs while other commands name its outputs. Checks, every run:
#   - each other command is refused at once, naming the running bake's pid;
#   - the running bake is not disturbed: it ends with exit 0;
#   - its .pvis and mesh are the reference bake's bytes (never a mismatched pair);
#   - two bakes started together onto one output: exactly one bakes, the other is refused
#     naming the first's pid;
#   - no temporary or lock file is left behind.
#
# Usage: tests/hostile/concurrent.sh PATCHVIS [RUNS] (RUNS defaults to 100).
# tests/hostile/locks.rs runs it with a few runs; run it by hand for the full count:
#   cargo build --release && tests/hostile/concurrent.sh target/release/patchvis 100
set -euo pipefail

patchvis=$(realpath "$1")
runs=${2:-100}
root=$(cd "$(dirname "$0")/../.." && pwd)
bunny="$root/assets/bunny.ply"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$work"

small=(--level 2 --resolution 128 --view-supersample 0 -q)
fail() {
    echo "run $run: $*" >&2
    exit 1
}

# The reference pair, baked alone.
"$patchvis" bake "$bunny" -o ref.pvis --mesh-out ref.ply "${small[@]}"

# Waits until the lock file $1 exists while process $2 runs; fails if it never appears.
wait_for_lock() {
    for _ in $(seq 1 6000); do
        [[ -e $1 ]] && return 0
        kill -0 "$2" 2>/dev/null || return 1
        sleep 0.005
    done
    return 1
}

# Runs "$@" and checks it was refused (exit 1 or 2) naming pid $holder.
refused() {
    local err status=0
    err=$("$patchvis" "$@" 2>&1 >/dev/null) || status=$?
    [[ $status == 1 || $status == 2 ]] || fail "not refused (exit $status): $* : $err"
    [[ $err == *"pid $holder"* ]] || fail "refusal does not name pid $holder: $* : $err"
}

# Checks that the outputs are the reference pair and nothing else was left.
check_outputs() {
    cmp -s out.pvis ref.pvis || fail "out.pvis is not the reference bake's"
    cmp -s out.ply ref.ply || fail "out.ply is not the reference bake's mesh"
    local left
    left=$(find . -name '*.patchvis-tmp' -o -name '*.patchvis-lock' -o -name '*.ckpt')
    [[ -z $left ]] || fail "left behind: $left"
}

for run in $(seq 1 "$runs"); do
    rm -f out.pvis out.ply other.pvis
    # A bake runs; other commands name its outputs.
    "$patchvis" bake "$bunny" -o out.pvis --mesh-out out.ply "${small[@]}" &
    holder=$!
    wait_for_lock .out.pvis.patchvis-lock "$holder" || fail "the bake never locked its output"
    refused bake missing.ply -o out.pvis "${small[@]}"
    refused bake "$bunny" -o other.pvis --mesh-out out.ply "${small[@]}"
    refused gen --kind truss --triangles 1000 -o out.ply -q
    refused bake "$bunny" -o out.pvis "${small[@]}"
    status=0
    wait "$holder" || status=$?
    [[ $status == 0 ]] || fail "the running bake was disturbed (exit $status)"
    [[ ! -e other.pvis ]] || fail "a refused bake wrote other.pvis"
    check_outputs

    # Two bakes started together onto one output pair: one bakes, the other is refused.
    rm -f out.pvis out.ply
    "$patchvis" bake "$bunny" -o out.pvis --mesh-out out.ply "${small[@]}" 2>first.err &
    first=$!
    "$patchvis" bake "$bunny" -o out.pvis --mesh-out out.ply "${small[@]}" 2>second.err &
    second=$!
    s1=0 s2=0
    wait "$first" || s1=$?
    wait "$second" || s2=$?
    if [[ $s1 == 0 && $s2 != 0 ]]; then
        grep -q "pid $first" second.err || fail "second refused without pid $first: $(cat second.err)"
    elif [[ $s2 == 0 && $s1 != 0 ]]; then
        grep -q "pid $second" first.err || fail "first refused without pid $second: $(cat first.err)"
    else
        fail "two bakes onto one output: exits $s1 and $s2, expected one 0 and one refusal"
    fi
    rm -f first.err second.err
    check_outputs
done
echo "concurrent: $runs runs passed"
