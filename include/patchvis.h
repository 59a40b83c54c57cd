/*
 * patchvis.h — C interface to the patchvis `.pvis` reader (Rust crate `patchvis`, feature
 * `capi`, source `src/capi.rs`). Hand-written; keep it in step with src/capi.rs.
 *
 * A `.pvis` file holds precomputed patch visibility for a triangle mesh (format:
 * spec/FORMAT.md). Parse it once — that validates every byte — then ask which patches a
 * camera at a position sees. Nothing allocates; nothing needs freeing.
 *
 *     PatchvisFile file;                          // caller-owned, e.g. on the stack
 *     int32_t rc = patchvis_parse(data, len, &file);
 *     if (rc != PATCHVIS_OK) { puts(patchvis_error_message(rc)); ... }
 *     size_t words = patchvis_scratch_words(&file);
 *     uint64_t *scratch = malloc(words * sizeof *scratch);
 *     PatchvisVisible vis;
 *     float eye[3] = {10.0f, 2.0f, -3.0f};
 *     patchvis_query(&file, eye, scratch, words, &vis);
 *     // patch p is visible iff (vis.bits[p / 64] >> (p % 64)) & 1
 *
 * Lifetime rule: the bytes given to patchvis_parse must stay valid and unmodified for as long
 * as the PatchvisFile is used. A query's answer lives in the caller's scratch buffer and stays
 * valid until that buffer is reused.
 *
 * Return codes: 0 success; negative: the API was misused (PATCHVIS_ERR_*); positive: the file
 * was refused, one code per kind of problem (1 truncated, 2 bad signature, 3 unsupported
 * version, 4 unknown flags, 5 length mismatch, 6 checksum mismatch, 7 missing section,
 * 8 duplicate section, 9 section shorter than its fixed part, 10 wrong section length,
 * 11 section out of bounds, 12 misaligned section, 13 limit exceeded, 14 invalid integer
 * field, 15 invalid float field, 16 view count mismatch, 17 non-contiguous patch ranges,
 * 18 triangle count mismatch, 19 unsupported visibility encoding, 20 padding bits set,
 * 99 other). patchvis_error_message names a code; patchvis_error_detail gives the precise
 * one-line reason with byte offsets and values.
 *
 * Thread safety: every function is reentrant; a parsed PatchvisFile may be queried from many
 * threads at once, each with its own scratch buffer. No function panics, aborts or allocates.
 *
 * Linking: build libpatchvis.a with
 *     cargo rustc --release --lib --no-default-features --features capi,std --crate-type staticlib
 * and link it with the system libraries rustc prints for `--print native-static-libs`
 * (on Linux typically -lgcc_s -lutil -lrt -lpthread -lm -ldl -lc). See tests/c/run.sh.
 */
#ifndef PATCHVIS_H
#define PATCHVIS_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Success. */
#define PATCHVIS_OK 0
/* A null pointer where one is required, or a length too large for the address space. */
#define PATCHVIS_ERR_ARGUMENT (-1)
/* The PatchvisFile was not filled by a successful patchvis_parse. */
#define PATCHVIS_ERR_NOT_PARSED (-2)
/* The scratch buffer is shorter than patchvis_scratch_words(). */
#define PATCHVIS_ERR_SCRATCH (-3)
/* A patch or view index past the end, or an output buffer too short for a row. */
#define PATCHVIS_ERR_RANGE (-4)

/* Size in bytes of a PatchvisFile. */
#define PATCHVIS_FILE_SIZE 512

/* Size in bytes of a PatchvisStream. */
#define PATCHVIS_STREAM_SIZE 8192

/* A parsed file, in memory the caller owns (8-byte aligned). Opaque: do not read or write
 * its contents; it holds pointers into the bytes given to patchvis_parse. It may be copied
 * with memcpy; the copy has the same lifetime rule. */
typedef struct PatchvisFile {
    uint64_t opaque[PATCHVIS_FILE_SIZE / 8];
} PatchvisFile;

/* A streaming query state (spec/FORMAT.md, section Query, Streaming), in memory the caller
 * owns (8-byte aligned). Opaque. It keeps the path of sphere faces to the last answer and their
 * decoded rows (in the scratch given to patchvis_stream_init), so a camera that stays in its
 * leaf costs a few plane tests and a move to a neighbouring leaf decodes only the rows it
 * needs. Not to be copied or shared between threads while in use. */
typedef struct PatchvisStream {
    uint64_t opaque[PATCHVIS_STREAM_SIZE / 8];
} PatchvisStream;

/* What a file holds (spec/FORMAT.md, sections Header, CAMR, PTCH). */
typedef struct PatchvisInfo {
    uint32_t version;        /* format version */
    uint32_t patch_count;    /* number of patches, at least 1 */
    uint64_t triangle_count; /* triangles the patches cover */
    uint32_t level;          /* sphere subdivision level, 0..7 */
    uint32_t views;          /* number of views, 4 * 4^level + 2 */
    float center[3];         /* centre of the model's bounding sphere */
    float radius;            /* its radius */
    float distance;          /* sampling cameras' distance from the centre */
    float fov_deg;           /* sampling cameras' full field of view, degrees */
    uint32_t resolution;     /* ID-buffer side, pixels */
    uint64_t total_bytes;    /* length of the file */
    size_t scratch_words;    /* uint64_t words of scratch a query needs */
} PatchvisInfo;

/* The answer to a query (spec/FORMAT.md, section Query). */
typedef struct PatchvisVisible {
    /* The visible set, in the caller's scratch: patch p is visible iff
     * (bits[p / 64] >> (p % 64)) & 1. Bits past the last patch are zero. */
    const uint64_t *bits;
    size_t words;            /* words at bits: ceil(patch_count / 64) */
    uint32_t leaf[3];        /* the three views of shell shells[0] whose rows were combined */
    uint32_t visible_count;  /* number of visible patches */
    uint32_t inside_sphere;  /* 1 if the eye is inside the innermost shell (the sampling sphere
                                for a file without shells): the answer is then approximate and
                                a renderer may prefer to draw everything */
    uint32_t band;           /* how many shells the eye is strictly inside, the sampling sphere
                                counted among them: 0 at or beyond shell 0, 1..K between
                                shells band - 1 and band, K + 1 inside shell K */
    uint32_t shells[2];      /* the shells whose rows were combined, outer first; the same
                                shell twice where one answered */
    uint32_t inner_leaf[3];  /* the three views of shell shells[1] whose rows were combined */
} PatchvisVisible;

/* One sampling shell (spec/FORMAT.md, section SHEL). Shells 0..K are numbered by decreasing
 * distance: shell J (patchvis_sampling_shell) is the sampling sphere, the others the file's
 * SHEL records, the J beyond the sampling distance (version 6's far band) before it and the
 * ones nearer the model after it. */
typedef struct PatchvisShell {
    float distance;          /* camera distance from the centre */
    uint32_t level;          /* sphere subdivision level of the shell's views */
    uint32_t views;          /* number of views, 4 * 4^level + 2 */
    uint32_t encoding;       /* VISB encoding of the shell's rows */
    uint64_t bytes;          /* bytes of the shell's rows */
} PatchvisShell;

/* K: the file's sampling shells besides the sampling sphere (0 for a file without SHEL, every
 * file of version 1-4); 0 for a NULL or unparsed file. */
uint32_t patchvis_shell_count(const PatchvisFile *file);

/* J: the shell number of the sampling sphere, the file's SHEL records beyond the sampling
 * distance (0 without them, every file of version 1-5); 0 for a NULL or unparsed file. */
uint32_t patchvis_sampling_shell(const PatchvisFile *file);

/* SHEL's reach: out to this distance from the centre, an eye between the sampling sphere and the
 * first far shell is answered by the sampling sphere alone (0: none, every file before version
 * 6 and one without a far band); 0 for a NULL or unparsed file. */
float patchvis_sampling_reach(const PatchvisFile *file);

/* Describes shell s (0..K, outermost first; J is the sampling sphere) in *out. Returns
 * PATCHVIS_OK, PATCHVIS_ERR_ARGUMENT (out NULL), PATCHVIS_ERR_NOT_PARSED or PATCHVIS_ERR_RANGE
 * (s > K). */
int32_t patchvis_shell(const PatchvisFile *file, uint32_t s, PatchvisShell *out);

/* sizeof(PatchvisFile) as the library was built; compare to catch a mismatched header. */
size_t patchvis_file_size(void);

/* Validates len bytes at data as a .pvis file and, on success, fills *out. `out` need not be
 * initialised. Returns PATCHVIS_OK, a positive file-error code, or PATCHVIS_ERR_ARGUMENT (out
 * null, or data null with len > 0). After a failure *out is marked unparsed and every other
 * call on it returns PATCHVIS_ERR_NOT_PARSED. data must outlive every use of *out. */
int32_t patchvis_parse(const uint8_t *data, size_t len, PatchvisFile *out);

/* A static NUL-terminated description of any return code; never NULL. */
const char *patchvis_error_message(int32_t code);

/* Writes the reader's precise one-line verdict on len bytes at data — the first rule the file
 * breaks, with byte offset and values (e.g. "section PTCH: patch 1 covers triangles 4+1,
 * expected a non-empty range starting at 3"), or "ok" — into buf, NUL-terminated and cut to
 * buf_len - 1 bytes. Returns the verdict's full length like snprintf (pass buf NULL, buf_len 0
 * to size a buffer). Parses the file again. */
size_t patchvis_error_detail(const uint8_t *data, size_t len, char *buf, size_t buf_len);

/* The parts patchvis_error_detail's message is made of, for a host that prints it itself
 * (the WebAssembly module's JavaScript): kind indexes the reader's message templates
 * (runtime::MESSAGE_TEMPLATES; kind = file-error code - 1) and values fill their holes in
 * order, unused ones 0. */
typedef struct PatchvisErrorParts {
    uint32_t kind;
    uint64_t values[6];
} PatchvisErrorParts;

/* Parses the file again; if it is refused, writes the parts of the reader's message to *out.
 * Returns PATCHVIS_OK (valid; *out untouched), the file-error code, or PATCHVIS_ERR_ARGUMENT. */
int32_t patchvis_error_parts(const uint8_t *data, size_t len, PatchvisErrorParts *out);

/* Fills *out. Returns PATCHVIS_OK, PATCHVIS_ERR_ARGUMENT or PATCHVIS_ERR_NOT_PARSED. */
int32_t patchvis_info(const PatchvisFile *file, PatchvisInfo *out);

/* uint64_t words of scratch patchvis_query needs; 0 for NULL or an unparsed file. */
size_t patchvis_scratch_words(const PatchvisFile *file);

/* Computes the patches visible from eye (model space) into scratch and describes them in
 * *out. An eye with a non-finite coordinate gets every patch, inside_sphere 1. scratch must
 * hold scratch_words >= patchvis_scratch_words(file) words and must not overlap the file's
 * bytes. Returns PATCHVIS_OK, PATCHVIS_ERR_ARGUMENT, PATCHVIS_ERR_NOT_PARSED or
 * PATCHVIS_ERR_SCRATCH. Cost: one point location and three rows ORed. */
int32_t patchvis_query(const PatchvisFile *file, const float eye[3], uint64_t *scratch,
                       size_t scratch_words, PatchvisVisible *out);

/* The triangle range [*first, *first + *count) of patch; consecutive patches have adjacent
 * ranges. Returns PATCHVIS_OK, PATCHVIS_ERR_ARGUMENT, PATCHVIS_ERR_NOT_PARSED or
 * PATCHVIS_ERR_RANGE (patch >= patch_count). */
int32_t patchvis_patch_range(const PatchvisFile *file, uint32_t patch, uint32_t *first,
                             uint32_t *count);

/* The merged triangle ranges of visible (an answer of patchvis_query or patchvis_stream_query
 * on this file): out[2*i] and out[2*i + 1] are the first triangle and the count of range i,
 * ascending, adjacent ranges merged; *ranges of them. Returns PATCHVIS_OK,
 * PATCHVIS_ERR_ARGUMENT, PATCHVIS_ERR_NOT_PARSED or PATCHVIS_ERR_RANGE (more ranges than
 * capacity: *ranges is then the number needed and out holds the first capacity).
 * capacity = (patch_count + 1) / 2 always suffices. One call instead of one
 * patchvis_patch_range per visible patch. */
int32_t patchvis_ranges(const PatchvisFile *file, const PatchvisVisible *visible, uint32_t *out,
                        size_t capacity, size_t *ranges);

/* Decodes the stored row of view into out[0 .. patchvis_scratch_words(file)), same bit
 * layout as a query's answer. Returns PATCHVIS_OK, PATCHVIS_ERR_ARGUMENT,
 * PATCHVIS_ERR_NOT_PARSED or PATCHVIS_ERR_RANGE (view >= views, or words too small). */
int32_t patchvis_view_row(const PatchvisFile *file, uint32_t view, uint64_t *out, size_t words);

/* sizeof(PatchvisStream) as the library was built. */
size_t patchvis_stream_size(void);

/* uint64_t words of scratch a streaming state needs: the decoded rows of its path, plus for
 * VISB encoding 2 a 32 KiB memo of tree walks. 0 for NULL or an unparsed file. */
size_t patchvis_stream_scratch_words(const PatchvisFile *file);

/* Starts a streaming state over file in *out, keeping its rows in scratch (at least
 * patchvis_stream_scratch_words(file) words; need not be initialised). The state holds its own
 * copy of the parsed reader, so *file may go, but the file's bytes and scratch must stay valid,
 * and scratch otherwise unused, while *out is used. Returns PATCHVIS_OK, PATCHVIS_ERR_ARGUMENT,
 * PATCHVIS_ERR_NOT_PARSED or PATCHVIS_ERR_SCRATCH; after a failure *out is unusable. */
int32_t patchvis_stream_init(const PatchvisFile *file, uint64_t *scratch, size_t scratch_words,
                             PatchvisStream *out);

/* The same answer as patchvis_query for eye, from the streaming state. out->bits points into
 * the state's scratch and stays valid until the next query on it. Returns PATCHVIS_OK,
 * PATCHVIS_ERR_ARGUMENT or PATCHVIS_ERR_NOT_PARSED (not from a successful
 * patchvis_stream_init). Cost (bunny, 2000 patches): 35 ns in a leaf, ~40 us on a leaf change,
 * against ~0.7 ms for every patchvis_query. */
int32_t patchvis_stream_query(PatchvisStream *stream, const float eye[3], PatchvisVisible *out);

/* Frustum culling (spec/FORMAT.md, section Frustum culling): the same answers without the
 * patches whose bounding spheres lie wholly outside the camera's view frustum, so one call
 * gives the set to draw. The test is conservative: a patch any part of which is inside is
 * kept, whatever the float rounding.
 *
 *     PatchvisFrustum fr;
 *     patchvis_frustum_from_view_proj(view_proj, PATCHVIS_DEPTH_ZERO_TO_ONE, &fr);  // once a frame
 *     patchvis_query_frustum(&file, eye, &fr, scratch, words, &vis);
 */

/* Clip-space depth ranges of patchvis_frustum_from_view_proj. */
#define PATCHVIS_DEPTH_NEGATIVE_ONE_TO_ONE 0 /* -w <= z <= w: OpenGL, WebGL */
#define PATCHVIS_DEPTH_ZERO_TO_ONE 1         /* 0 <= z <= w: Direct3D, Vulkan, Metal, wgpu */

/* A view frustum as six planes {a, b, c, d}, each keeping the model-space points with
 * a*x + b*y + c*z + d >= 0 (any scale, any order). Fill it with
 * patchvis_frustum_from_view_proj, or write the planes yourself; {0, 0, 0, 1} drops nothing.
 * Any values are safe: NaN or infinities keep every patch. */
typedef struct PatchvisFrustum {
    float planes[6][4];
} PatchvisFrustum;

/* Fills *out with the frustum of a column-major view-projection matrix (model space to clip
 * space; element (row, col) at m[4 * col + row], as OpenGL, WebGPU and glam store it), for
 * clip coordinates with -w <= x, y <= w and depth's range of z. Returns PATCHVIS_OK or
 * PATCHVIS_ERR_ARGUMENT (a NULL pointer, or depth not one of PATCHVIS_DEPTH_*). */
int32_t patchvis_frustum_from_view_proj(const float m[16], int32_t depth, PatchvisFrustum *out);

/* As patchvis_query, without the patches the frustum drops: the set to draw, in scratch.
 * Returns the codes of patchvis_query (PATCHVIS_ERR_ARGUMENT also for a NULL frustum).
 * Cost: patchvis_query's, plus one patch record decoded and tested per visible patch. */
int32_t patchvis_query_frustum(const PatchvisFile *file, const float eye[3],
                               const PatchvisFrustum *frustum, uint64_t *scratch,
                               size_t scratch_words, PatchvisVisible *out);

/* As patchvis_stream_query, without the patches the frustum drops. The answer is written to
 * bits (words >= patchvis_scratch_words(file); not the state's scratch, whose cached answer
 * the next query reuses), and out->bits points there. Returns PATCHVIS_OK,
 * PATCHVIS_ERR_ARGUMENT, PATCHVIS_ERR_NOT_PARSED or PATCHVIS_ERR_RANGE (words too small). */
int32_t patchvis_stream_query_frustum(PatchvisStream *stream, const float eye[3],
                                      const PatchvisFrustum *frustum, uint64_t *bits,
                                      size_t words, PatchvisVisible *out);

#ifdef __cplusplus
}
#endif

#endif /* PATCHVIS_H */
