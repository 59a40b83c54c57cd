/*
 * query.c — exercises the patchvis C ABI (include/patchvis.h) on one .pvis file.
 *
 *     query FILE.pvis [X,Y,Z ...]
 *     query FILE.pvis --frustum [X,Y,Z ...]
 *
 * For a valid file prints, in the conformance dump's format (tests/conformance/README.md),
 * the header counts, every patch's triangle range, every view's row and one `query` line per
 * position given (checking on the way that patchvis_ranges merges the visible ranges); the positions are echoed as given, so the lines compare byte for byte with
 * the expected dump. For a refused file prints `error: <the reader's one-line verdict>` and
 * exits 1. tests/c/run.sh compares both against the conformance vectors.
 *
 * With --frustum, prints instead one line per finite position: a camera there looking at a
 * point half a radius beside the model's centre (OpenGL perspective, 40 degrees), its
 * view-projection matrix and the frustum-culled answer of patchvis_query_frustum, checked on
 * the way against patchvis_stream_query_frustum, against patchvis_query (a subset of it) and
 * against a frustum given as planes. run.sh compares it with `patchvis query --view-proj`.
 */
#include <math.h>
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

/* Column-major OpenGL look-at times perspective (vertical fov, aspect 1), rounded to float. */
static void view_projection(const double eye[3], const double target[3], double fov_deg,
                            double near, double far, float out[16]) {
    double f[3], s[3], u[3], len = 0;
    for (int k = 0; k < 3; k++) f[k] = target[k] - eye[k], len += f[k] * f[k];
    for (int k = 0; k < 3; k++) f[k] /= sqrt(len);
    double up[3] = {0, 1, 0};
    if (fabs(f[1]) > 0.999) up[1] = 0, up[2] = 1;
    s[0] = f[1] * up[2] - f[2] * up[1];
    s[1] = f[2] * up[0] - f[0] * up[2];
    s[2] = f[0] * up[1] - f[1] * up[0];
    len = sqrt(s[0] * s[0] + s[1] * s[1] + s[2] * s[2]);
    for (int k = 0; k < 3; k++) s[k] /= len;
    u[0] = s[1] * f[2] - s[2] * f[1];
    u[1] = s[2] * f[0] - s[0] * f[2];
    u[2] = s[0] * f[1] - s[1] * f[0];
    double view[16] = {s[0], u[0], -f[0], 0, s[1], u[1], -f[1], 0, s[2], u[2], -f[2], 0,
                       -(s[0] * eye[0] + s[1] * eye[1] + s[2] * eye[2]),
                       -(u[0] * eye[0] + u[1] * eye[1] + u[2] * eye[2]),
                       f[0] * eye[0] + f[1] * eye[1] + f[2] * eye[2], 1};
    double g = 1.0 / tan(fov_deg * 3.14159265358979323846 / 360.0);
    double proj[16] = {g, 0, 0, 0, 0, g, 0, 0, 0, 0, (far + near) / (near - far), -1,
                       0, 0, 2 * far * near / (near - far), 0};
    for (int i = 0; i < 16; i++) {
        double v = 0;
        for (int k = 0; k < 4; k++) v += proj[4 * k + i % 4] * view[4 * (i / 4) + k];
        out[i] = (float)v;
    }
}

/* The --frustum mode: see the header comment. */
static int frustum_lines(const PatchvisFile *file, const PatchvisInfo *info, int count,
                         char **positions) {
    size_t words = patchvis_scratch_words(file);
    size_t stream_words = patchvis_stream_scratch_words(file);
    uint64_t *scratch = calloc(words, sizeof *scratch), *plain = calloc(words, sizeof *plain);
    uint64_t *bits = calloc(words, sizeof *bits);
    uint64_t *stream_scratch = malloc(stream_words * sizeof *stream_scratch);
    PatchvisStream stream;
    if (!scratch || !plain || !bits || !stream_scratch ||
        patchvis_stream_init(file, stream_scratch, stream_words, &stream) != PATCHVIS_OK)
        return 3;
    for (int i = 0; i < count; i++) {
        float eye[3];
        char *end = positions[i];
        for (int k = 0; k < 3; k++) {
            eye[k] = strtof(end, &end);
            if (*end == ',') end++;
        }
        if (!isfinite(eye[0]) || !isfinite(eye[1]) || !isfinite(eye[2])) continue;
        double e[3] = {eye[0], eye[1], eye[2]};
        double t[3] = {info->center[0] + 0.5 * info->radius, info->center[1], info->center[2]};
        double d = sqrt((t[0] - e[0]) * (t[0] - e[0]) + (t[1] - e[1]) * (t[1] - e[1]) +
                        (t[2] - e[2]) * (t[2] - e[2]));
        if (!(d > 0)) continue;
        float m[16];
        view_projection(e, t, 40.0, 0.01 * d, 2.0 * d, m);
        PatchvisFrustum fr;
        if (patchvis_frustum_from_view_proj(m, 7, &fr) != PATCHVIS_ERR_ARGUMENT) return 6;
        if (patchvis_frustum_from_view_proj(m, PATCHVIS_DEPTH_NEGATIVE_ONE_TO_ONE, &fr) !=
            PATCHVIS_OK)
            return 6;
        PatchvisVisible vis, streamed, all;
        if (patchvis_query(file, eye, plain, words, &all) != PATCHVIS_OK) return 6;
        if (patchvis_query_frustum(file, eye, &fr, scratch, words, &vis) != PATCHVIS_OK) return 6;
        if (patchvis_stream_query_frustum(&stream, eye, &fr, bits, words, &streamed) !=
                PATCHVIS_OK ||
            streamed.bits != bits || streamed.visible_count != vis.visible_count ||
            memcmp(bits, scratch, words * sizeof *bits) != 0)
            return 6;
        /* A subset of the plain answer; the same planes written by hand (scaled by 2, in
         * another order) give the same answer. */
        PatchvisFrustum by_hand;
        for (int p = 0; p < 6; p++)
            for (int k = 0; k < 4; k++) by_hand.planes[5 - p][k] = 2.0f * fr.planes[p][k];
        if (patchvis_query_frustum(file, eye, &by_hand, bits, words, &streamed) != PATCHVIS_OK ||
            memcmp(bits, scratch, words * sizeof *bits) != 0)
            return 6;
        for (size_t w = 0; w < words; w++)
            if (scratch[w] & ~plain[w]) return 6;
        printf("frustum %s ", positions[i]);
        for (int k = 0; k < 16; k++) printf("%s%.9g", k ? "," : "", m[k]);
        printf(" -> [");
        uint32_t listed = 0;
        for (uint32_t p = 0; p < info->patch_count; p++)
            if ((scratch[p / 64] >> (p % 64)) & 1) printf("%s%u", listed++ ? "," : "", p);
        printf("]\n");
        if (listed != vis.visible_count) return 6;
    }
    /* Misuse is reported, not crashed on. */
    if (patchvis_query_frustum(file, (const float[3]){0, 0, 0}, NULL, scratch, words, NULL) !=
        PATCHVIS_ERR_ARGUMENT)
        return 6;
    if (words > 0 && patchvis_stream_query_frustum(&stream, (const float[3]){0, 0, 0},
                                                   &(PatchvisFrustum){0}, bits, words - 1,
                                                   &(PatchvisVisible){0}) != PATCHVIS_ERR_RANGE)
        return 6;
    free(stream_scratch);
    free(bits);
    free(plain);
    free(scratch);
    return 0;
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
    if (argc >= 3 && strcmp(argv[2], "--frustum") == 0) {
        int rc = frustum_lines(&file, &info, argc - 3, argv + 3);
        free(data);
        return rc;
    }
    printf("patches: %u\ntriangles: %llu\nlevel: %u\nviews: %u\n", info.patch_count,
           (unsigned long long)info.triangle_count, info.level, info.views);
    for (uint32_t p = 0; p < info.patch_count; p++) {
        uint32_t first, count;
        if (patchvis_patch_range(&file, p, &first, &count) != PATCHVIS_OK) return 3;
        printf("patch %u: first %u count %u\n", p, first, count);
    }

    /* Sampling shells: 0..K by decreasing distance, the sampling sphere among them (shell 0
     * unless the file has a far band, version 6). It is the one at the sampling distance,
     * which no SHEL record may have; the others are the SHEL records. */
    uint32_t shells = patchvis_shell_count(&file), sampling = shells + 1;
    PatchvisShell shell;
    if (patchvis_shell(&file, shells + 1, &shell) != PATCHVIS_ERR_RANGE ||
        patchvis_shell(&file, 0, NULL) != PATCHVIS_ERR_ARGUMENT)
        return 3;
    for (uint32_t k = 0; k <= shells; k++) {
        if (patchvis_shell(&file, k, &shell) != PATCHVIS_OK) return 3;
        if (shell.distance != info.distance) continue;
        if (sampling <= shells || shell.level != info.level || shell.views != info.views) return 3;
        sampling = k;
    }
    if (sampling > shells) return 3;
    if (shells > 0) printf("shells: %u\n", shells);
    for (uint32_t k = 0; k <= shells; k++) {
        if (k == sampling) continue;
        if (patchvis_shell(&file, k, &shell) != PATCHVIS_OK) return 3;
        printf("shell %u: distance %g level %u views %u encoding %u bytes %llu\n", k,
               shell.distance, shell.level, shell.views, shell.encoding,
               (unsigned long long)shell.bytes);
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
            streamed.inside_sphere != vis.inside_sphere || streamed.band != vis.band ||
            memcmp(streamed.shells, vis.shells, sizeof vis.shells) != 0 ||
            memcmp(streamed.leaf, vis.leaf, sizeof vis.leaf) != 0 ||
            memcmp(streamed.inner_leaf, vis.inner_leaf, sizeof vis.inner_leaf) != 0 ||
            memcmp(streamed.bits, vis.bits, words * sizeof *vis.bits) != 0)
            return 4;
        printf("query %s -> inside %s", argv[i], vis.inside_sphere ? "true" : "false");
        /* A file with shells also says which band and shells answered. */
        if (shells > 0) printf(" band %u shells [%u,%u]", vis.band, vis.shells[0], vis.shells[1]);
        printf(" views [%u,%u,%u]", vis.leaf[0], vis.leaf[1], vis.leaf[2]);
        if (shells > 0)
            printf(" inner [%u,%u,%u]", vis.inner_leaf[0], vis.inner_leaf[1], vis.inner_leaf[2]);
        printf(" patches [");
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
