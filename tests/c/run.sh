#!/usr/bin/env bash
# Builds libpatchvis.a (feature `capi`), compiles tests/c/query.c against include/patchvis.h
# with `cc`, and compares its output with every conformance vector's expectation: the header
# counts, patch ranges, view rows and query lines of each valid vector's dump, and the exact
# error line of each invalid vector. Then the frustum queries (query.c --frustum) against the
# Rust reader's answers through `patchvis query --view-proj` (a debug build of the binary).
# Used by .ci/run; needs cargo and a C compiler.
set -euo pipefail
cd "$(dirname "$0")/../.."

# A separate target dir: the staticlib's feature set would otherwise evict the main build's
# artefacts from target/release.
target=target/capi
mkdir -p "$target"
cargo rustc --quiet --release --lib --no-default-features --features capi,std \
    --crate-type staticlib --target-dir "$target" -- --print native-static-libs \
    2> "$target-native-libs.txt" || { cat "$target-native-libs.txt"; exit 1; }
native=$(sed -n 's/.*native-static-libs: //p' "$target-native-libs.txt" | tail -n 1)

cc -std=c11 -Wall -Wextra -Werror -pedantic -O2 -Iinclude tests/c/query.c \
    "$target/release/libpatchvis.a" $native -lm -o "$target/query"
cargo build --quiet --bin patchvis
patchvis="${CARGO_TARGET_DIR:-target}/debug/patchvis"

fail=0
for vector in tests/conformance/valid/*.pvis; do
    dump="${vector%.pvis}.dump"
    mapfile -t positions < <(sed -n 's/^query \([^ ]*\) .*/\1/p' "$dump")
    expected=$(grep -E '^(patches|triangles|level|views|shells): |^(patch|view|shell) [0-9]+: |^query ' "$dump")
    if ! actual=$("$target/query" "$vector" "${positions[@]}"); then
        echo "FAIL $vector: query.c exited with an error"; fail=1; continue
    fi
    if [[ "$actual" != "$expected" ]]; then
        echo "FAIL $vector:"; diff <(echo "$expected") <(echo "$actual") | head -20; fail=1
    fi
done
frusta=0
for vector in tests/conformance/valid/*.pvis; do
    dump="${vector%.pvis}.dump"
    mapfile -t positions < <(sed -n 's/^query \([^ ]*\) .*/\1/p' "$dump")
    if ! lines=$("$target/query" "$vector" --frustum "${positions[@]}"); then
        echo "FAIL $vector: query.c --frustum exited with an error"; fail=1; continue
    fi
    while read -r _ eye matrix _ answer; do
        expected=$("$patchvis" query "$vector" --eye "$eye" --view-proj "$matrix" --json |
            sed -n 's/.*"patches":\(\[[^]]*\]\).*/\1/p')
        if [[ "$answer" != "$expected" ]]; then
            echo "FAIL $vector frustum from $eye: C $answer, Rust $expected"; fail=1
        fi
        frusta=$((frusta + 1))
    done <<< "$lines"
done
for vector in tests/conformance/invalid/*.pvis; do
    expected="error: $(cat "${vector%.pvis}.err")"
    set +e
    actual=$("$target/query" "$vector" 2>/dev/null)
    rc=$?
    set -e
    if [[ $rc -ne 1 || "$actual" != "$expected" ]]; then
        echo "FAIL $vector: exit $rc"; diff <(echo "$expected") <(echo "$actual"); fail=1
    fi
done
valid=$(ls tests/conformance/valid/*.pvis | wc -l)
invalid=$(ls tests/conformance/invalid/*.pvis | wc -l)
if [[ $fail -ne 0 ]]; then echo "C ABI: FAILED"; exit 1; fi
echo "C ABI: $valid valid and $invalid invalid vectors match their expectations;" \
    "$frusta frustum queries match patchvis query"
