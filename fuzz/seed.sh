#!/usr/bin/env bash
# Seeds fuzz/corpus/parse_query from the conformance vectors: each input is 24 bytes of eye
# positions (here the eye (0,0,0) twice; the fuzzer mutates them) followed by the vector.
# Idempotent. The roundtrip target starts from an empty corpus (its input is structured).
set -euo pipefail
cd "$(dirname "$0")"
mkdir -p corpus/parse_query corpus/roundtrip
for vector in ../tests/conformance/valid/*.pvis ../tests/conformance/invalid/*.pvis; do
    { head -c 24 /dev/zero; cat "$vector"; } > "corpus/parse_query/seed-$(basename "$vector" .pvis)"
done
ls corpus/parse_query | wc -l
