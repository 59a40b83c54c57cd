#!/usr/bin/env bash
# Builds libpatchvis.a (feature `capi`), compiles tests/c/query.c against include/patchvis.h
# with `cc`, and compares its output with every conformance vector's expectation: the header
# counts, patch ranges, shells (in order; the dump's `sampling shell` and `sampling reach` lines),
# view rows and every query line of each valid vector's dump (other dump lines are not
# compared), and the exact error line of each invalid vector; tests/c/serve.c through
# `patchvis conformance`. Then, against the Rust reader's
# answers through `patchvis query` (a debug build of the binary): the frustum queries
# (query.c --frustum), and a version-6 bake (far shells beyond the sampling distance) queried
# in every band, from 1000 sampling distances out to its centre (query.c --bands). Used by
# .ci/run; needs cargo and a C compiler.
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
cc -std=c11 -Wall -Wextra -Werror -pedantic -O2 -Iinclude tests/c/serve.c \
    "$target/release/libpatchvis.a" $native -lm -o "$target/serve"
cargo build --quiet --bin patchvis
patchvis="${CARGO_TARGET_DIR:-target}/debug/patchvis"

# The C ABI through the conformance harness (tests/conformance/README.md, "Testing another
# reader"): every vector, truncated copies and frustum queries included.
harness=$("$patchvis" conformance --reader "$target/serve") ||
    { grep -v '^pass ' <<< "$harness"; echo "C ABI: conformance harness FAILED"; exit 1; }
tail -n 1 <<< "$harness"

# The lines compared, in order. A shell's number is left out: the dump and query.c may number
# the SHEL records differently, and the order says which is which.
compared() {
    grep -E '^(patches|triangles|level|views|shells): |^(patch|view|shell) [0-9]+: |^query ' |
        sed 's/^shell [0-9]*: /shell: /'
}

fail=0
queries=0
for vector in tests/conformance/valid/*.pvis; do
    dump="${vector%.pvis}.dump"
    mapfile -t positions < <(sed -n 's/^query \([^ ]*\) .*/\1/p' "$dump")
    expected=$(compared < "$dump")
    if ! output=$("$target/query" "$vector" "${positions[@]}"); then
        echo "FAIL $vector: query.c exited with an error"; fail=1; continue
    fi
    actual=$(compared <<< "$output")
    if [[ "$actual" != "$expected" ]]; then
        echo "FAIL $vector:"; diff <(echo "$expected") <(echo "$actual") | head -20 || true; fail=1
    fi
    # Version-5 dumps have no `sampling shell` line; a `sampling reach` line is where the reach
    # is not 0, in the dump as in query.c's output.
    for line in 'sampling shell' 'sampling reach'; do
        dumped=$(grep "^$line: " "$dump" || true)
        printed=$(grep "^$line: " <<< "$output" || true)
        if [[ ( -n $dumped || $line == 'sampling reach' ) && $dumped != "$printed" ]]; then
            echo "FAIL $vector: '$printed', the dump says '$dumped'"; fail=1
        fi
    done
    queries=$((queries + ${#positions[@]}))
done
# The frustum queries of $1 from the positions after it against `patchvis query`.
frusta=0
frustum_check() {
    local file=$1 lines
    shift
    if ! lines=$("$target/query" "$file" --frustum "$@"); then
        echo "FAIL $file: query.c --frustum exited with an error"; fail=1; return
    fi
    while read -r _ eye matrix _ answer; do
        expected=$("$patchvis" query "$file" --eye "$eye" --view-proj "$matrix" --json |
            sed -n 's/.*"patches":\(\[[^]]*\]\).*/\1/p')
        if [[ "$answer" != "$expected" ]]; then
            echo "FAIL $file frustum from $eye: C $answer, Rust $expected"; fail=1
        fi
        frusta=$((frusta + 1))
    done <<< "$lines"
}
for vector in tests/conformance/valid/*.pvis; do
    mapfile -t positions < <(sed -n 's/^query \([^ ]*\) .*/\1/p' "${vector%.pvis}.dump")
    frustum_check "$vector" "${positions[@]}"
done
# A version-6 bake (the default far and near shells, a small quick bake of the globe) in every
# band against `patchvis query`.
far="$target/far.pvis"
"$patchvis" bake tests/data/obj/globe.obj -o "$far" --patches 16 --level 2 --resolution 64 --quiet
bands_out=$("$target/query" "$far" --bands)
mapfile -t eyes < <(grep -v ':' <<< "$bands_out")
shells=$(sed -n 's/^shells: //p' <<< "$bands_out")
sampling=$(sed -n 's/^sampling shell: //p' <<< "$bands_out")
if ! lines=$("$target/query" "$far" "${eyes[@]}" | grep '^query '); then
    echo "FAIL $far: query.c exited with an error"; fail=1
fi
# A field of `patchvis query --json`'s one line: a number, true/false or a list.
field() { sed -n "s/.*\"$1\":\(\[[^]]*\]\|[a-z0-9]*\).*/\1/p" <<< "$json"; }
declare -A bands=()
while read -r line; do
    eye=$(cut -d' ' -f2 <<< "$line")
    json=$("$patchvis" query "$far" --from "$eye" --json)
    expected="query $eye -> inside $(field inside_sphere) band $(field band) shells $(field shells)"
    expected+=" views $(field views) inner $(field inner_views) patches $(field patches)"
    if [[ "$line" != "$expected" ]]; then
        echo "FAIL $far from $eye: C $line"; echo "     Rust $expected"; fail=1
    fi
    bands[$(field band)]=1
done <<< "$lines"
if [[ -z $sampling || $sampling -eq 0 || ${#bands[@]} -ne $((shells + 2)) ]]; then
    echo "FAIL $far: ${#bands[@]} bands queried, sampling shell '$sampling' of '$shells'"; fail=1
fi
frustum_check "$far" "${eyes[@]}"
for vector in tests/conformance/invalid/*.pvis; do
    expected="error: $(cat "${vector%.pvis}.err")"
    set +e
    actual=$("$target/query" "$vector" 2>/dev/null)
    rc=$?
    set -e
    if [[ $rc -ne 1 || "$actual" != "$expected" ]]; then
        echo "FAIL $vector: exit $rc"; diff <(echo "$expected") <(echo "$actual") || true; fail=1
    fi
done
valid=$(ls tests/conformance/valid/*.pvis | wc -l)
invalid=$(ls tests/conformance/invalid/*.pvis | wc -l)
if [[ $fail -ne 0 ]]; then echo "C ABI: FAILED"; exit 1; fi
echo "C ABI: $valid valid and $invalid invalid vectors match their expectations ($queries" \
    "queries); $frusta frustum queries and ${#eyes[@]} queries of a version-6 bake in all" \
    "$((shells + 2)) bands (sampling shell $sampling) match patchvis query"
