/*
 * query.c — exercises the patchvis C ABI (include/patchvis.h) on one .pvis file.
 *
 *     query FILE.pvis [X,Y,Z ...]
 *     query FILE.pvis --bands
 *     query FILE.pvis --frustum [X,Y,Z ...]
 *
 * For a valid file prints, in the conformance dump's format (tests/conformance/README.md),
 * the header counts, every patch's triangle range, the shells (their count, the sampling
 * sphere's number J and every other shell's record), every view's row and one `query` line
 * per position given, checking on the way that patchvis_ranges merges the visible ranges and
 * that the band and answering shells follow the band rule; the positions are echoed as
 * given, so the lines compare byte for byte with the expected dump. For a refused file prints
 * `error: <the reader's one-line verdict>` and exits 1. tests/c/run.sh compares both against
 * the conformance vectors.
 *
 * With --bands, prints after the header counts, ranges and shells the positions to query
 * instead (one X,Y,Z a line, no colon): eyes in every band of the file's shells, from 1000
 * sampling distances out to the centre. run.sh queries them and compares the answers with
 * `patchvis query`.
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

/* Most shells a file has besides the sampling sphere (spec/FORMAT.md, Resource limits). */
#define MAX_SHELLS 8

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

/* The --bands mode: see the header comment. Eyes in three directions at radii in every band:
 * beyond the outermost shell (up to 1000 times the sampling distance), between each two
 * shells (their geometric mean), on the sampling sphere and inside the innermost shell. */
static void band_positions(const PatchvisInfo *info, const float *distances, uint32_t shells,
                           float reach) {
    double radii[2 * MAX_SHELLS + 9];
    size_t n = 0;
    radii[n++] = 1000.0 * info->distance;
    radii[n++] = 1.5 * distances[0];
    for (uint32_t s = 1; s <= shells; s++) radii[n++] = sqrt((double)distances[s - 1] * distances[s]);
    radii[n++] = info->distance;
    /* Between the sampling distance and the reach, where the sampling sphere answers alone. */
    if (reach > 0) radii[n++] = 0.5 * ((double)info->distance + reach);
    radii[n++] = 0.9 * distances[shells];
    radii[n++] = 0.5 * distances[shells];
    static const double directions[3][3] = {
        {0.36, 0.48, 0.8}, {-0.6, 0.64, -0.48}, {0.0, -0.6, 0.8}};
    for (size_t i = 0; i < n; i++)
        for (int k = 0; k < 3; k++) {
            const double *u = directions[k];
            printf("%.9g,%.9g,%.9g\n", (float)(info->center[0] + radii[i] * u[0]),
                   (float)(info->center[1] + radii[i] * u[1]),
                   (float)(info->center[2] + radii[i] * u[2]));
        }
    /* The centre itself: inside every shell. */
    printf("%.9g,%.9g,%.9g\n", info->center[0], info->center[1], info->center[2]);
}

/* Checks an answer against the band rule (spec/FORMAT.md, section Query): the band counts the
 * shells the eye is inside (checked where the eye is not within a few ulps of a shell's
 * sphere, which the reader decides in its own float arithmetic); band 0 answers from shell 0,
 * 1..K from shells band - 1 and band, K + 1 from shell K with inside_sphere; band J (the
 * sampling shell) nearer than SHEL's reach from shell J alone. */
static int check_band(const PatchvisInfo *info, const float eye[3], const float *distances,
                      uint32_t shells, uint32_t sampling, float reach,
                      const PatchvisVisible *vis) {
    if (!isfinite(eye[0]) || !isfinite(eye[1]) || !isfinite(eye[2]))
        return vis->band == shells + 1 && vis->inside_sphere ? 0 : 1;
    double d2 = 0;
    for (int k = 0; k < 3; k++) d2 += ((double)eye[k] - info->center[k]) * (eye[k] - info->center[k]);
    for (uint32_t s = 0; s <= shells; s++) {
        double r2 = (double)distances[s] * distances[s];
        if (d2 < r2 * (1 - 1e-5) && vis->band <= s) return 1;
        if (d2 > r2 * (1 + 1e-5) && vis->band > s) return 1;
    }
    uint32_t outer = vis->band == 0 ? 0 : vis->band - 1;
    uint32_t inner = vis->band > shells ? shells : vis->band;
    if (vis->band == sampling && sampling > 0) {
        double r2 = (double)reach * reach;
        if (d2 < r2 * (1 - 1e-5) || (d2 <= r2 * (1 + 1e-5) && vis->shells[0] == sampling))
            outer = sampling;
    }
    if (vis->band > shells + 1 || vis->shells[0] != outer || vis->shells[1] != inner ||
        vis->inside_sphere != (vis->band == shells + 1))
        return 1;
    return 0;
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

    /* Sampling shells 0..K by decreasing distance: shell J is the sampling sphere, the others
     * the SHEL records (J of them beyond the sampling distance, version 6). */
    uint32_t shells = patchvis_shell_count(&file);
    uint32_t sampling = patchvis_sampling_shell(&file);
    float distances[MAX_SHELLS + 1];
    PatchvisShell shell;
    if (shells > MAX_SHELLS || sampling > shells || patchvis_sampling_shell(NULL) != 0 ||
        patchvis_shell(&file, shells + 1, &shell) != PATCHVIS_ERR_RANGE ||
        patchvis_shell(&file, 0, NULL) != PATCHVIS_ERR_ARGUMENT ||
        patchvis_shell(&file, sampling, &shell) != PATCHVIS_OK || shell.level != info.level ||
        shell.views != info.views || shell.distance != info.distance)
        return 3;
    if (shells > 0) printf("shells: %u\nsampling shell: %u\n", shells, sampling);
    float reach = patchvis_sampling_reach(&file);
    if (patchvis_sampling_reach(NULL) != 0 || (reach != 0 && !(sampling > 0 && reach > info.distance)))
        return 3;
    if (reach != 0) printf("sampling reach: %g\n", reach);
    for (uint32_t s = 0; s <= shells; s++) {
        if (patchvis_shell(&file, s, &shell) != PATCHVIS_OK) return 3;
        distances[s] = shell.distance;
        if (s > 0 && !(shell.distance < distances[s - 1])) return 3;
        if (s == sampling) continue;
        printf("shell %u: distance %g level %u views %u encoding %u bytes %llu\n", s,
               shell.distance, shell.level, shell.views, shell.encoding,
               (unsigned long long)shell.bytes);
    }
    if (argc >= 3 && strcmp(argv[2], "--bands") == 0) {
        band_positions(&info, distances, shells, reach);
        free(data);
        return 0;
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
        if (check_band(&info, eye, distances, shells, sampling, reach, &vis) != 0) return 4;
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
