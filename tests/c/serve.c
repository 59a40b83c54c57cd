/*
 * serve.c — the patchvis C ABI (include/patchvis.h) as a peer of `patchvis conformance`:
 * answers the harness's line protocol (tests/conformance/README.md, "Testing another
 * reader") on stdin and stdout, one reply line per request line.
 *
 *     patchvis conformance --reader tests/c/serve      (built by tests/c/run.sh)
 *
 * Declares `frustum`. A refused file is answered with the reader's one-line verdict
 * (patchvis_error_detail).
 */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "patchvis.h"

/* Longest request line: a path, or an eye and 16 numbers. */
#define LINE 16384

static uint8_t *data;
static size_t len;
static PatchvisFile file;
static PatchvisInfo info;
static int open_ok;
static uint64_t *scratch;

static uint8_t *read_file(const char *path, size_t *n) {
    FILE *f = fopen(path, "rb");
    if (!f) return NULL;
    size_t cap = 1 << 16, used = 0, got;
    uint8_t *buf = malloc(cap);
    while (buf && (got = fread(buf + used, 1, cap - used, f)) > 0) {
        used += got;
        if (used == cap) {
            uint8_t *bigger = realloc(buf, cap *= 2);
            if (!bigger) free(buf);
            buf = bigger;
        }
    }
    fclose(f);
    *n = used;
    return buf;
}

/* Parses `count` comma-separated floats from `text` (`inf`, `-inf` as strtof reads them); the
 * end of what was read, or NULL. */
static char *numbers(char *text, float *out, int count) {
    char *end = text;
    for (int k = 0; k < count; k++) {
        out[k] = strtof(end, &end);
        if (k + 1 < count && *end++ != ',') return NULL;
    }
    return end;
}

static void print_bits(const uint64_t *bits, uint32_t patches) {
    uint32_t listed = 0;
    printf("[");
    for (uint32_t p = 0; p < patches; p++)
        if ((bits[p / 64] >> (p % 64)) & 1) printf("%s%u", listed++ ? "," : "", p);
    printf("]");
}

static void open_file(const char *path) {
    free(data);
    free(scratch);
    data = NULL;
    scratch = NULL;
    open_ok = 0;
    data = read_file(path, &len);
    if (!data) {
        printf("error %s: cannot read\n", path);
        return;
    }
    if (patchvis_parse(data, len, &file) != PATCHVIS_OK) {
        char detail[1024];
        patchvis_error_detail(data, len, detail, sizeof detail);
        printf("error %s\n", detail);
        return;
    }
    scratch = calloc(patchvis_scratch_words(&file) + 1, sizeof *scratch);
    open_ok = scratch != NULL && patchvis_info(&file, &info) == PATCHVIS_OK;
    printf(open_ok ? "ok\n" : "error out of memory\n");
}

static void query(char *args) {
    float eye[3];
    char *end = numbers(args, eye, 3);
    if (!end || *end != '\0') {
        printf("error bad eye '%s'\n", args);
        return;
    }
    PatchvisVisible vis;
    if (patchvis_query(&file, eye, scratch, patchvis_scratch_words(&file), &vis) != PATCHVIS_OK) {
        printf("error query failed\n");
        return;
    }
    printf("inside %s band %u shells [%u,%u] views [%u,%u,%u] inner [%u,%u,%u] patches ",
           vis.inside_sphere ? "true" : "false", vis.band, vis.shells[0], vis.shells[1],
           vis.leaf[0], vis.leaf[1], vis.leaf[2], vis.inner_leaf[0], vis.inner_leaf[1],
           vis.inner_leaf[2]);
    print_bits(vis.bits, info.patch_count);
    printf("\n");
}

static void frustum(char *args) {
    float eye[3], m[16];
    char *end = numbers(args, eye, 3);
    char depth_word[16];
    int used = 0;
    if (!end || sscanf(end, " %15s %n", depth_word, &used) != 1) {
        printf("error bad frustum request\n");
        return;
    }
    int32_t depth = strcmp(depth_word, "gl") == 0            ? PATCHVIS_DEPTH_NEGATIVE_ONE_TO_ONE
                    : strcmp(depth_word, "zero-to-one") == 0 ? PATCHVIS_DEPTH_ZERO_TO_ONE
                                                             : -1;
    end = numbers(end + used, m, 16);
    PatchvisFrustum fr;
    PatchvisVisible vis;
    if (depth < 0 || !end || *end != '\0' ||
        patchvis_frustum_from_view_proj(m, depth, &fr) != PATCHVIS_OK ||
        patchvis_query_frustum(&file, eye, &fr, scratch, patchvis_scratch_words(&file), &vis) !=
            PATCHVIS_OK) {
        printf("error bad frustum request\n");
        return;
    }
    printf("patches ");
    print_bits(vis.bits, info.patch_count);
    printf("\n");
}

int main(void) {
    static char line[LINE];
    while (fgets(line, sizeof line, stdin)) {
        line[strcspn(line, "\r\n")] = '\0';
        char *args = strchr(line, ' ');
        if (args) *args++ = '\0';
        else args = line + strlen(line);
        if (strcmp(line, "hello") == 0) printf("hello 1 frustum\n");
        else if (strcmp(line, "open") == 0) open_file(args);
        else if (strcmp(line, "quit") == 0) break;
        else if (!open_ok) printf("error no file is open\n");
        else if (strcmp(line, "query") == 0) query(args);
        else if (strcmp(line, "frustum") == 0) frustum(args);
        else printf("error unknown request '%s'\n", line);
        fflush(stdout);
    }
    free(data);
    free(scratch);
    return 0;
}
