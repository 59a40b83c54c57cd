/*
 * query.c — exercises the patchvis C ABI (include/patchvis.h) on one .pvis file.
 *
 *     query FILE.pvis [X,Y,Z ...]
 *
 * For a valid file prints, in the conformance dump's format (tests/conformance/README.md),
 * the header counts, every patch's triangle range, every view's row and one `query` line per
 * position given (checking on the way that patchvis_ranges merges the visible ranges); the positions are echoed as given, so the lines compare byte for byte with
 * the expected dump. For a refused file prints `error: <the reader's one-line verdict>` and
 * exits 1. tests/c/run.sh compares both against the conformance vectors.
 */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "patchvis.h"

static uint8_t *read_file(const char *path, size_t *len) {
    FILE *f = fopen(path, "rb");
    if (!f) return NULL;
    size_t cap = 1 << 16, n = 0;
    uint8_t *buf = malloc(cap);
    size_t got;
    while (buf && (got = fread(buf + n, 1, cap - n, f)) > 0) {
        n += got;
        if (n == cap) {
            uint8_t *bigger = realloc(buf, cap *= 2);
            if (!bigger) { free(buf); buf = NULL; }
            buf = bigger;
        }
    }
    fclose(f);
    *len = n;
    return buf;
}

static void print_bits(const uint64_t *bits, uint32_t patches) {
    for (uint32_t p = 0; p < patches; p++) putchar((bits[p / 64] >> (p % 64)) & 1 ? '1' : '0');
}

int main(int argc, char **argv) {
    if (argc < 2) {
        fprintf(stderr, "usage: %s FILE.pvis [X,Y,Z ...]\n", argv[0]);
        return 2;
    }
    if (patchvis_file_size() != sizeof(PatchvisFile)) {
        fprintf(stderr, "header and library disagree on sizeof(PatchvisFile)\n");
        return 2;
    }
    size_t len = 0;
    uint8_t *data = read_file(argv[1], &len);
    if (!data) {
        fprintf(stderr, "%s: cannot read\n", argv[1]);
        return 2;
    }

    PatchvisFile file;
    int32_t rc = patchvis_parse(data, len, &file);
    if (rc != PATCHVIS_OK) {
        size_t need = patchvis_error_detail(data, len, NULL, 0);
        char *detail = malloc(need + 1);
        if (!detail) return 2;
        patchvis_error_detail(data, len, detail, need + 1);
        printf("error: %s\n", detail);
        /* A refused handle must refuse every later call. */
        if (patchvis_scratch_words(&file) != 0) return 3;
        PatchvisInfo none;
        if (patchvis_info(&file, &none) != PATCHVIS_ERR_NOT_PARSED) return 3;
        fprintf(stderr, "code %d: %s\n", rc, patchvis_error_message(rc));
        free(detail);
        free(data);
        return 1;
    }

    PatchvisInfo info;
    if (patchvis_info(&file, &info) != PATCHVIS_OK) return 3;
    printf("patches: %u\ntriangles: %llu\nlevel: %u\nviews: %u\n", info.patch_count,
           (unsigned long long)info.triangle_count, info.level, info.views);
    for (uint32_t p = 0; p < info.patch_count; p++) {
        uint32_t first, count;
        if (patchvis_patch_range(&file, p, &first, &count) != PATCHVIS_OK) return 3;
        printf("patch %u: first %u count %u\n", p, first, count);
    }

    size_t words = patchvis_scratch_words(&file);
    uint64_t *scratch = calloc(words, sizeof *scratch);
    if (!scratch || words != info.scratch_words) return 3;
    if (patchvis_stream_size() != sizeof(PatchvisStream)) return 3;
    size_t stream_words = patchvis_stream_scratch_words(&file);
    uint64_t *stream_scratch = malloc(stream_words * sizeof *stream_scratch);
    PatchvisStream stream;
    if (!stream_scratch ||
        patchvis_stream_init(&file, stream_scratch, stream_words - 1, &stream) !=
            PATCHVIS_ERR_SCRATCH ||
        patchvis_stream_init(&file, stream_scratch, stream_words, &stream) != PATCHVIS_OK)
        return 3;
    for (uint32_t v = 0; v < info.views; v++) {
        if (patchvis_view_row(&file, v, scratch, words) != PATCHVIS_OK) return 3;
        printf("view %u: ", v);
        print_bits(scratch, info.patch_count);
        putchar('\n');
    }

    for (int i = 2; i < argc; i++) {
        float eye[3];
        char *end = argv[i];
        for (int k = 0; k < 3; k++) {
            eye[k] = strtof(end, &end);
            if (*end == ',') end++;
        }
        if (*end != '\0') {
            fprintf(stderr, "bad position '%s'\n", argv[i]);
            return 2;
        }
        PatchvisVisible vis;
        if (patchvis_query(&file, eye, scratch, words, &vis) != PATCHVIS_OK) return 3;
        if (vis.bits != scratch || vis.words != words) return 3;
        /* The streaming state gives the same answer. */
        PatchvisVisible streamed;
        if (patchvis_stream_query(&stream, eye, &streamed) != PATCHVIS_OK) return 3;
        if (streamed.words != words || streamed.visible_count != vis.visible_count ||
            streamed.inside_sphere != vis.inside_sphere ||
            memcmp(streamed.leaf, vis.leaf, sizeof vis.leaf) != 0 ||
            memcmp(streamed.bits, vis.bits, words * sizeof *vis.bits) != 0)
            return 4;
        printf("query %s -> inside %s views [%u,%u,%u] patches [", argv[i],
               vis.inside_sphere ? "true" : "false", vis.leaf[0], vis.leaf[1], vis.leaf[2]);
        uint32_t listed = 0;
        for (uint32_t p = 0; p < info.patch_count; p++) {
            if ((vis.bits[p / 64] >> (p % 64)) & 1) printf("%s%u", listed++ ? "," : "", p);
        }
        printf("]\n");
        if (listed != vis.visible_count) return 3;
        /* patchvis_ranges gives the visible patches' ranges merged, in one call: the same as
         * merging patchvis_patch_range by hand. */
        size_t capacity = (info.patch_count + 1) / 2, n = 0, m = 0;
        uint32_t *ranges = malloc(2 * capacity * sizeof *ranges);
        uint32_t *merged = malloc(2 * capacity * sizeof *merged);
        if (!ranges || !merged || patchvis_ranges(&file, &vis, ranges, capacity, &n) != PATCHVIS_OK)
            return 5;
        for (uint32_t p = 0; p < info.patch_count; p++) {
            uint32_t first, count;
            if (!((vis.bits[p / 64] >> (p % 64)) & 1)) continue;
            if (patchvis_patch_range(&file, p, &first, &count) != PATCHVIS_OK) return 5;
            if (m > 0 && merged[2 * (m - 1)] + merged[2 * (m - 1) + 1] == first) {
                merged[2 * (m - 1) + 1] += count;
            } else {
                if (m == capacity) return 5;
                merged[2 * m] = first;
                merged[2 * m + 1] = count;
                m++;
            }
        }
        if (m != n || memcmp(merged, ranges, 2 * n * sizeof *ranges) != 0) return 5;
        free(merged);
        free(ranges);
    }
    /* Misuse is reported, not crashed on. */
    if (patchvis_query(&file, NULL, scratch, words, NULL) != PATCHVIS_ERR_ARGUMENT) return 3;
    if (words > 0 && patchvis_query(&file, (const float[3]){0, 0, 0}, scratch, 0, NULL) !=
                         PATCHVIS_ERR_ARGUMENT)
        return 3;
    uint32_t first, count;
    if (patchvis_patch_range(&file, info.patch_count, &first, &count) != PATCHVIS_ERR_RANGE)
        return 3;

    free(stream_scratch);
    free(scratch);
    free(data);
    return 0;
}
