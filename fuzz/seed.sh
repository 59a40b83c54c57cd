#!/usr/bin/env bash
# Seeds fuzz/corpus/parse_query from the conformance vectors: each input is 24 bytes of eye
# positions (here the eye (0,0,0) twice; the fuzzer mutates them) followed by the vector.
# Seeds fuzz/corpus/part with the parts of a small sharded bunny bake (raw mode: a 0 byte,
# then the file) and with inputs of the damaged and crafted modes (a 1 byte, seven bytes of
# shape and damage, then row bits), where a built patchvis is found (PATCHVIS, or
# ../target/release/patchvis). Idempotent. The roundtrip target starts from an empty corpus
# (its input is structured).
set -euo pipefail
cd "$(dirname "$0")"
mkdir -p corpus/parse_query corpus/roundtrip
for vector in ../tests/conformance/valid/*.pvis ../tests/conformance/invalid/*.pvis; do
    { head -c 24 /dev/zero; cat "$vector"; } > "corpus/parse_query/seed-$(basename "$vector" .pvis)"
done
ls corpus/parse_query | wc -l
mkdir -p corpus/part
for shape in '\x01\x01\x40\x01\x00\x10\x2c\x30' '\x01\x02\x8a\x03\x01\x05\x80\xff' \
    '\x01\x03\x41\x02\x01\x22\x60\x00' '\x01\x01\x02\x00\x00\x3f\xc8\x7f'; do
    { printf "$shape"; head -c 256 /dev/zero | tr '\0' '\125'; } > "corpus/part/seed-crafted-$(printf "$shape" | od -An -tx1 | tr -d ' \n')"
done
patchvis=${PATCHVIS:-../target/release/patchvis}
if [ -x "$patchvis" ]; then
    work=$(mktemp -d)
    trap 'rm -rf "$work"' EXIT
    small=(--level 1 --resolution 64 --view-supersample 0 --patches 40 -q)
    "$patchvis" tile ../assets/bunny.ply -o "$work/t.ptile" --patches 40 -q
    for i in 0 1; do
        "$patchvis" bake ../assets/bunny.ply -o "$work/p$i.ppart" --tiling-file "$work/t.ptile" \
            --shard "$i/2" "${small[@]}"
        { printf '\x00'; cat "$work/p$i.ppart"; } > "corpus/part/seed-raw-$i"
    done
fi
# The cache target: a replacement that is empty, and patches of zeros and of 0xff bytes.
mkdir -p corpus/cache
printf '\x00' > corpus/cache/seed-empty
{ printf '\x01'; head -c 96 /dev/zero; } > corpus/cache/seed-zeros
{ printf '\x01'; head -c 96 /dev/zero | tr '\0' '\377'; } > corpus/cache/seed-ones
ls corpus/part | wc -l
