/*
 * vox_read.c — MagicaVoxel .vox import, from memory, bounded and checked.
 *
 * Format: ephtracy/voxel-model, "MagicaVoxel-file-format-vox.txt" (RIFF-style chunks: a
 * 4-byte id, content size N, children size M; MAIN holds every other chunk; PACK, SIZE,
 * XYZI, RGBA, the default palette, MATT) and "MagicaVoxel-file-format-vox-extension.txt"
 * (STRING, DICT, ROTATION, the nTRN/nGRP/nSHP scene graph, MATL, LAYR, IMAP; rOBJ, rCAM,
 * NOTE are skipped by their size). Placement follows what MagicaVoxel does and what
 * opengametools' ogt_vox and vengi reproduce: a model's pivot is floor(size/2), and a voxel
 * at p lands in the cell floor(R * (p + 0.5 - floor(size/2)) + t), with (R, t) the product
 * of the transforms on the path from the root. docs/vox.md has the whole mapping.
 *
 * Every read goes through vox_reader, which knows the end of the current chunk; every count
 * is checked against the bytes left before anything is allocated from it; the scene graph
 * is walked with an explicit stack (no recursion depth to exhaust), loops are caught by an
 * on-path mark, and vw_vox_limits caps instances, voxels, node visits and world size.
 *
 * The budget (vw_budget) is checked from the parsed scene before the world exists: the
 * instances' solid voxels against max_voxels, then the world's table plus one dense chunk
 * for every distinct chunk an instanced voxel lands in (counted exactly, with a bit per chunk
 * of the table) against max_bytes. A file on disk is checked before it is read: a regular
 * file (not a FIFO or a device), no larger than max_bytes, with the magic in its first
 * bytes; only as many bytes as its MAIN chunk claims are read.
 */
#define _POSIX_C_SOURCE 200809L

#include "vox_format.h"
#include "vw_internal.h"

#include <errno.h>
#include <fcntl.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#define VOX_ID(a, b, c, d) ((uint32_t)(a) | (uint32_t)(b) << 8 | (uint32_t)(c) << 16 | (uint32_t)(d) << 24)
#define ID_VOX  VOX_ID('V', 'O', 'X', ' ')
#define ID_MAIN VOX_ID('M', 'A', 'I', 'N')
#define ID_PACK VOX_ID('P', 'A', 'C', 'K')
#define ID_SIZE VOX_ID('S', 'I', 'Z', 'E')
#define ID_XYZI VOX_ID('X', 'Y', 'Z', 'I')
#define ID_RGBA VOX_ID('R', 'G', 'B', 'A')
#define ID_MATT VOX_ID('M', 'A', 'T', 'T')
#define ID_MATL VOX_ID('M', 'A', 'T', 'L')
#define ID_nTRN VOX_ID('n', 'T', 'R', 'N')
#define ID_nGRP VOX_ID('n', 'G', 'R', 'P')
#define ID_nSHP VOX_ID('n', 'S', 'H', 'P')
#define ID_LAYR VOX_ID('L', 'A', 'Y', 'R')
#define ID_IMAP VOX_ID('I', 'M', 'A', 'P')

/* MagicaVoxel's own models are at most 256 per axis (XYZI coordinates are bytes); a
 * larger SIZE can only add empty space, which we tolerate up to this much. */
#define VOX_MAX_MODEL_EDGE 1024
/* The world's axis limit (vw_world_create accepts up to 1<<20 voxels per axis). */
#define VOX_MAX_AXIS ((int64_t)1 << 20)
/* Scene coordinates stay far inside int64 and inside the world's origin range (2^60). */
#define VOX_MAX_COORD ((int64_t)1 << 58)

const uint32_t vw_vox_default_palette[256] = {
    0x00000000, 0xffffffff, 0xffccffff, 0xff99ffff, 0xff66ffff, 0xff33ffff, 0xff00ffff, 0xffffccff,
    0xffccccff, 0xff99ccff, 0xff66ccff, 0xff33ccff, 0xff00ccff, 0xffff99ff, 0xffcc99ff, 0xff9999ff,
    0xff6699ff, 0xff3399ff, 0xff0099ff, 0xffff66ff, 0xffcc66ff, 0xff9966ff, 0xff6666ff, 0xff3366ff,
    0xff0066ff, 0xffff33ff, 0xffcc33ff, 0xff9933ff, 0xff6633ff, 0xff3333ff, 0xff0033ff, 0xffff00ff,
    0xffcc00ff, 0xff9900ff, 0xff6600ff, 0xff3300ff, 0xff0000ff, 0xffffffcc, 0xffccffcc, 0xff99ffcc,
    0xff66ffcc, 0xff33ffcc, 0xff00ffcc, 0xffffcccc, 0xffcccccc, 0xff99cccc, 0xff66cccc, 0xff33cccc,
    0xff00cccc, 0xffff99cc, 0xffcc99cc, 0xff9999cc, 0xff6699cc, 0xff3399cc, 0xff0099cc, 0xffff66cc,
    0xffcc66cc, 0xff9966cc, 0xff6666cc, 0xff3366cc, 0xff0066cc, 0xffff33cc, 0xffcc33cc, 0xff9933cc,
    0xff6633cc, 0xff3333cc, 0xff0033cc, 0xffff00cc, 0xffcc00cc, 0xff9900cc, 0xff6600cc, 0xff3300cc,
    0xff0000cc, 0xffffff99, 0xffccff99, 0xff99ff99, 0xff66ff99, 0xff33ff99, 0xff00ff99, 0xffffcc99,
    0xffcccc99, 0xff99cc99, 0xff66cc99, 0xff33cc99, 0xff00cc99, 0xffff9999, 0xffcc9999, 0xff999999,
    0xff669999, 0xff339999, 0xff009999, 0xffff6699, 0xffcc6699, 0xff996699, 0xff666699, 0xff336699,
    0xff006699, 0xffff3399, 0xffcc3399, 0xff993399, 0xff663399, 0xff333399, 0xff003399, 0xffff0099,
    0xffcc0099, 0xff990099, 0xff660099, 0xff330099, 0xff000099, 0xffffff66, 0xffccff66, 0xff99ff66,
    0xff66ff66, 0xff33ff66, 0xff00ff66, 0xffffcc66, 0xffcccc66, 0xff99cc66, 0xff66cc66, 0xff33cc66,
    0xff00cc66, 0xffff9966, 0xffcc9966, 0xff999966, 0xff669966, 0xff339966, 0xff009966, 0xffff6666,
    0xffcc6666, 0xff996666, 0xff666666, 0xff336666, 0xff006666, 0xffff3366, 0xffcc3366, 0xff993366,
    0xff663366, 0xff333366, 0xff003366, 0xffff0066, 0xffcc0066, 0xff990066, 0xff660066, 0xff330066,
    0xff000066, 0xffffff33, 0xffccff33, 0xff99ff33, 0xff66ff33, 0xff33ff33, 0xff00ff33, 0xffffcc33,
    0xffcccc33, 0xff99cc33, 0xff66cc33, 0xff33cc33, 0xff00cc33, 0xffff9933, 0xffcc9933, 0xff999933,
    0xff669933, 0xff339933, 0xff009933, 0xffff6633, 0xffcc6633, 0xff996633, 0xff666633, 0xff336633,
    0xff006633, 0xffff3333, 0xffcc3333, 0xff993333, 0xff663333, 0xff333333, 0xff003333, 0xffff0033,
    0xffcc0033, 0xff990033, 0xff660033, 0xff330033, 0xff000033, 0xffffff00, 0xffccff00, 0xff99ff00,
    0xff66ff00, 0xff33ff00, 0xff00ff00, 0xffffcc00, 0xffcccc00, 0xff99cc00, 0xff66cc00, 0xff33cc00,
    0xff00cc00, 0xffff9900, 0xffcc9900, 0xff999900, 0xff669900, 0xff339900, 0xff009900, 0xffff6600,
    0xffcc6600, 0xff996600, 0xff666600, 0xff336600, 0xff006600, 0xffff3300, 0xffcc3300, 0xff993300,
    0xff663300, 0xff333300, 0xff003300, 0xffff0000, 0xffcc0000, 0xff990000, 0xff660000, 0xff330000,
    0xff0000ee, 0xff0000dd, 0xff0000bb, 0xff0000aa, 0xff000088, 0xff000077, 0xff000055, 0xff000044,
    0xff000022, 0xff000011, 0xff00ee00, 0xff00dd00, 0xff00bb00, 0xff00aa00, 0xff008800, 0xff007700,
    0xff005500, 0xff004400, 0xff002200, 0xff001100, 0xffee0000, 0xffdd0000, 0xffbb0000, 0xffaa0000,
    0xff880000, 0xff770000, 0xff550000, 0xff440000, 0xff220000, 0xff110000, 0xffeeeeee, 0xffdddddd,
    0xffbbbbbb, 0xffaaaaaa, 0xff888888, 0xff777777, 0xff555555, 0xff444444, 0xff222222, 0xff111111,
};

/* ---- bounded reading ---------------------------------------------------------------- */

/* A cursor over [pos, end) of the file; end is the end of the current chunk's content, so a
 * field can never be read from the next chunk. Offsets are absolute (for messages). */
typedef struct vox_reader {
    const uint8_t *data;
    size_t pos;
    size_t end;
} vox_reader;

static size_t rd_left(const vox_reader *r) { return r->end - r->pos; }

static uint32_t le32(const uint8_t *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

static int rd_u32(vox_reader *r, uint32_t *v)
{
    if (rd_left(r) < 4)
        return 0;
    *v = le32(r->data + r->pos);
    r->pos += 4;
    return 1;
}

static int rd_i32(vox_reader *r, int32_t *v)
{
    uint32_t u;
    if (!rd_u32(r, &u))
        return 0;
    /* Two's complement, without relying on implementation-defined conversion. */
    *v = u <= 0x7FFFFFFFu ? (int32_t)u : (int32_t)(u - 0x80000000u) - 0x7FFFFFFF - 1;
    return 1;
}

static int rd_f32(vox_reader *r, float *v)
{
    uint32_t u;
    if (!rd_u32(r, &u))
        return 0;
    memcpy(v, &u, sizeof *v);
    return 1;
}

/* A length-prefixed STRING (extension spec (a)): not NUL-terminated, so it stays a span. */
typedef struct vox_str {
    const uint8_t *p;
    size_t n;
} vox_str;

static int str_is(vox_str s, const char *lit)
{
    size_t n = strlen(lit);
    return s.p && s.n == n && memcmp(s.p, lit, n) == 0;
}

/* ---- the parse state ---------------------------------------------------------------- */

typedef struct vox_model {
    int32_t size[3];
    uint32_t count;        /* XYZI entries                                                  */
    uint32_t solid;        /* of those, the ones with a colour (colour 0 is empty)          */
    size_t voxels;         /* file offset of the first (x, y, z, colour) entry              */
} vox_model;

/* A signed permutation matrix, the only rotations .vox can express: row i has its one
 * non-zero entry, sign[i] (+1/-1), in column col[i]. */
typedef struct vox_rot {
    int8_t col[3];
    int8_t sign[3];
} vox_rot;

enum { NODE_TRN = 1, NODE_GRP = 2, NODE_SHP = 3 };

typedef struct vox_node {
    int32_t id;
    uint8_t type;
    uint8_t hidden;       /* _hidden = 1 in the node's attributes                          */
    uint8_t rotated;      /* nTRN: rotation is not the identity                            */
    vox_rot rot;          /* nTRN, frame 0                                                 */
    int32_t t[3];         /* nTRN, frame 0                                                 */
    int32_t child;        /* nTRN: child node id                                           */
    int32_t layer;        /* nTRN: layer id (-1: none)                                     */
    int32_t model;        /* nSHP: frame-0 model id (-1: the shape has no model)           */
    uint32_t child_count; /* nGRP                                                          */
    size_t children;      /* nGRP: file offset of child_count int32 node ids               */
    size_t chunk;         /* file offset of the node's chunk header, for messages          */
} vox_node;

typedef struct vox_layer {
    int32_t id;
    uint8_t hidden;
    uint32_t order;       /* file order: the last LAYR of an id wins                       */
} vox_layer;

typedef struct vox_inst {
    uint32_t model;
    vox_rot rot;
    int64_t t[3];
    uint32_t chunk_id;    /* the nSHP (or XYZI) that made it, for messages                 */
    size_t chunk;
} vox_inst;

typedef struct vox_ctx {
    const uint8_t *data;
    size_t size;
    vw_error *err;
    vw_vox_limits lim;
    vw_budget budget;            /* defaults filled in                                      */
    int building;                /* a world is wanted: the budget applies                  */
    uint64_t instanced_solid;    /* sum over instances of their model's solid voxels        */
    /* The chunk being read, named in error messages. */
    uint32_t chunk_id;
    size_t chunk_off;

    vox_model *models;
    uint32_t model_count, model_cap;
    int pending_size;            /* a SIZE waits for its XYZI                               */
    int32_t pending[3];
    size_t pending_off;

    vox_node *nodes;
    uint32_t node_count, node_cap;
    vox_layer *layers;
    uint32_t layer_count, layer_cap;

    vox_inst *inst;
    uint32_t inst_count, inst_cap;

    uint32_t palette[256];       /* by colour index, 0xAABBGGRR                             */
    uint32_t flags[256];         /* VW_MAT_* by colour index                                */
    uint8_t imap[256];
    int has_imap;

    vw_vox_stats st;
} vox_ctx;

/* Names the chunk in messages; fuzzed ids are not always printable. */
static void chunk_name(uint32_t id, char out[5])
{
    for (int i = 0; i < 4; i++) {
        unsigned char c = (unsigned char)(id >> (8 * i));
        out[i] = c >= 0x20 && c < 0x7F ? (char)c : '?';
    }
    out[4] = 0;
}

/* Every format error leaves through here: the message names the byte offset of the
 * offending field and the chunk it lies in. */
static vw_status vox_fail(vox_ctx *c, vw_status status, size_t offset, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 4, 5)))
#endif
    ;

static vw_status vox_fail(vox_ctx *c, vw_status status, size_t offset, const char *fmt, ...)
{
    if (c->err) {
        char what[300];
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(what, sizeof what, fmt, ap);
        va_end(ap);
        if (c->chunk_id) {
            char name[5];
            chunk_name(c->chunk_id, name);
            snprintf(c->err->message, sizeof c->err->message,
                     ".vox: %s at byte offset %zu (chunk '%s' at byte offset %zu)", what, offset, name,
                     c->chunk_off);
        } else {
            snprintf(c->err->message, sizeof c->err->message, ".vox: %s at byte offset %zu (file header)", what,
                     offset);
        }
    }
    return status;
}

/* A short read inside a chunk: the content size says less than the fields need. */
static vw_status short_read(vox_ctx *c, const vox_reader *r, const char *what, size_t need)
{
    return vox_fail(c, VW_ERROR_FORMAT, r->pos, "%s needs %zu bytes but the chunk has %zu left", what, need,
                    rd_left(r));
}

/* Grows an array to hold one more element, doubling; the callers' counts are bounded by the
 * file size (each element needs bytes in the file), so this cannot run away. */
static int grow(void **array, uint32_t *cap, uint32_t count, size_t elem)
{
    if (count < *cap)
        return 1;
    uint32_t n = *cap ? *cap * 2 : 16;
    if (n <= *cap || (size_t)n > SIZE_MAX / elem)
        return 0;
    void *p = realloc(*array, (size_t)n * elem);
    if (!p)
        return 0;
    *array = p;
    *cap = n;
    return 1;
}

static vw_status oom(vox_ctx *c, size_t offset)
{
    return vox_fail(c, VW_ERROR_OUT_OF_MEMORY, offset, "out of memory");
}

/* ---- STRING / DICT and the numbers inside them ------------------------------------- */

static vw_status rd_string(vox_ctx *c, vox_reader *r, vox_str *out)
{
    size_t at = r->pos;
    int32_t n;
    if (!rd_i32(r, &n))
        return short_read(c, r, "a STRING length", 4);
    if (n < 0)
        return vox_fail(c, VW_ERROR_FORMAT, at, "negative STRING length %d", (int)n);
    if ((size_t)n > rd_left(r))
        return short_read(c, r, "a STRING", (size_t)n);
    out->p = r->data + r->pos;
    out->n = (size_t)n;
    r->pos += (size_t)n;
    return VW_OK;
}

/* Reads a DICT (extension spec (b)) and keeps the values of the keys asked for (the last
 * one wins when a key repeats); the others are checked for size and skipped. */
static vw_status rd_dict(vox_ctx *c, vox_reader *r, const char *const *keys, vox_str *values, int nkeys)
{
    for (int k = 0; k < nkeys; k++)
        values[k].p = NULL, values[k].n = 0;
    size_t at = r->pos;
    int32_t n;
    if (!rd_i32(r, &n))
        return short_read(c, r, "a DICT size", 4);
    if (n < 0)
        return vox_fail(c, VW_ERROR_FORMAT, at, "negative DICT size %d", (int)n);
    /* Each pair needs at least 8 bytes: a cheap bound before the loop. */
    if ((size_t)n > rd_left(r) / 8)
        return vox_fail(c, VW_ERROR_FORMAT, at, "DICT of %d pairs cannot fit in the %zu bytes left", (int)n,
                        rd_left(r));
    for (int32_t i = 0; i < n; i++) {
        vox_str key, value;
        vw_status s = rd_string(c, r, &key);
        if (s == VW_OK)
            s = rd_string(c, r, &value);
        if (s != VW_OK)
            return s;
        for (int k = 0; k < nkeys; k++)
            if (str_is(key, keys[k]))
                values[k] = value;
    }
    return VW_OK;
}

static int is_space(uint8_t ch) { return ch == ' ' || ch == '\t' || ch == '\n' || ch == '\r'; }

/* One decimal integer at *i in s (leading blanks allowed), within [lo, hi]. The number
 * parsers here are ours: strtol/strtod need NUL-terminated input and depend on the locale. */
static int scan_int(vox_str s, size_t *i, int64_t lo, int64_t hi, int64_t *out)
{
    size_t k = *i;
    while (k < s.n && is_space(s.p[k]))
        k++;
    int neg = 0;
    if (k < s.n && (s.p[k] == '-' || s.p[k] == '+'))
        neg = s.p[k++] == '-';
    size_t digits = 0;
    int64_t v = 0;
    while (k < s.n && s.p[k] >= '0' && s.p[k] <= '9') {
        if (v > ((int64_t)1 << 40))
            return 0; /* far beyond any limit below: stop before overflow */
        v = v * 10 + (s.p[k++] - '0');
        digits++;
    }
    if (!digits)
        return 0;
    if (neg)
        v = -v;
    if (v < lo || v > hi)
        return 0;
    *out = v;
    *i = k;
    return 1;
}

/* The whole string is `count` integers separated by blanks. */
static int parse_ints(vox_str s, int count, int64_t lo, int64_t hi, int64_t *out)
{
    size_t i = 0;
    for (int k = 0; k < count; k++) {
        if (k > 0 && (i >= s.n || !is_space(s.p[i])))
            return 0;
        if (!scan_int(s, &i, lo, hi, &out[k]))
            return 0;
    }
    while (i < s.n && is_space(s.p[i]))
        i++;
    return i == s.n;
}

/* A decimal real ("0.1", "1", "-2.5e-3"); 0 when malformed. Precision only needs to be
 * enough to compare material parameters with thresholds. */
static int parse_real(vox_str s, double *out)
{
    size_t i = 0;
    while (i < s.n && is_space(s.p[i]))
        i++;
    double sign = 1.0, v = 0.0;
    if (i < s.n && (s.p[i] == '-' || s.p[i] == '+'))
        sign = s.p[i++] == '-' ? -1.0 : 1.0;
    size_t digits = 0;
    while (i < s.n && s.p[i] >= '0' && s.p[i] <= '9') {
        if (v < 1e300)
            v = v * 10.0 + (s.p[i] - '0');
        i++, digits++;
    }
    if (i < s.n && s.p[i] == '.') {
        i++;
        double scale = 0.1;
        while (i < s.n && s.p[i] >= '0' && s.p[i] <= '9') {
            v += (s.p[i++] - '0') * scale;
            scale *= 0.1;
            digits++;
        }
    }
    if (!digits)
        return 0;
    if (i < s.n && (s.p[i] == 'e' || s.p[i] == 'E')) {
        i++;
        int64_t e;
        if (!scan_int(s, &i, -400, 400, &e))
            return 0;
        for (; e > 0; e--)
            v = v < 1e300 ? v * 10.0 : v;
        for (; e < 0; e++)
            v *= 0.1;
    }
    while (i < s.n && is_space(s.p[i]))
        i++;
    if (i != s.n)
        return 0;
    *out = sign * v;
    return 1;
}

/* ---- rotations (extension spec (c)) ------------------------------------------------- */

static const vox_rot rot_identity = {{0, 1, 2}, {1, 1, 1}};

/* The ROTATION byte: bits 0-1 the column of row 0's non-zero entry, bits 2-3 that of row 1
 * (row 2 takes the remaining column), bits 4/5/6 the signs of rows 0/1/2. Identity is 4. */
static int rot_decode(int64_t bits, vox_rot *out)
{
    if (bits < 0 || bits > 127)
        return 0;
    int c0 = (int)(bits & 3), c1 = (int)((bits >> 2) & 3);
    if (c0 > 2 || c1 > 2 || c0 == c1)
        return 0;
    out->col[0] = (int8_t)c0;
    out->col[1] = (int8_t)c1;
    out->col[2] = (int8_t)(3 - c0 - c1);
    for (int i = 0; i < 3; i++)
        out->sign[i] = (int8_t)((bits >> (4 + i)) & 1 ? -1 : 1);
    return 1;
}

static int rot_is_identity(const vox_rot *r)
{
    return r->col[0] == 0 && r->col[1] == 1 && r->col[2] == 2 && r->sign[0] == 1 && r->sign[1] == 1 &&
           r->sign[2] == 1;
}

/* a * b: row i of a picks row col_a[i] of b, scaled by sign_a[i]. */
static vox_rot rot_mul(const vox_rot *a, const vox_rot *b)
{
    vox_rot r;
    for (int i = 0; i < 3; i++) {
        r.col[i] = b->col[a->col[i]];
        r.sign[i] = (int8_t)(a->sign[i] * b->sign[a->col[i]]);
    }
    return r;
}

/* ---- chunks ------------------------------------------------------------------------- */

static vw_status read_size(vox_ctx *c, vox_reader *r)
{
    if (c->pending_size)
        return vox_fail(c, VW_ERROR_FORMAT, c->chunk_off, "SIZE follows the SIZE at byte offset %zu without an XYZI",
                        c->pending_off);
    for (int a = 0; a < 3; a++) {
        size_t at = r->pos;
        if (!rd_i32(r, &c->pending[a]))
            return short_read(c, r, "SIZE", 12);
        if (c->pending[a] < 1 || c->pending[a] > VOX_MAX_MODEL_EDGE)
            return vox_fail(c, VW_ERROR_FORMAT, at, "model size %d on axis %c: must be in 1..%d",
                            (int)c->pending[a], "xyz"[a], VOX_MAX_MODEL_EDGE);
    }
    c->pending_size = 1;
    c->pending_off = c->chunk_off;
    return VW_OK;
}

static vw_status read_xyzi(vox_ctx *c, vox_reader *r)
{
    if (!c->pending_size)
        return vox_fail(c, VW_ERROR_FORMAT, c->chunk_off, "XYZI without a SIZE before it");
    c->pending_size = 0;
    size_t at = r->pos;
    int32_t n;
    if (!rd_i32(r, &n))
        return short_read(c, r, "the XYZI voxel count", 4);
    if (n < 0)
        return vox_fail(c, VW_ERROR_FORMAT, at, "negative XYZI voxel count %d", (int)n);
    if ((size_t)n > rd_left(r) / 4)
        return vox_fail(c, VW_ERROR_FORMAT, at, "XYZI count %d needs %llu bytes but the chunk has %zu", (int)n,
                        (unsigned long long)n * 4u, rd_left(r));
    const uint8_t *v = r->data + r->pos;
    uint32_t solid = 0;
    for (int32_t i = 0; i < n; i++) {
        solid += v[4 * (size_t)i + 3] != 0;
        for (int a = 0; a < 3; a++)
            if (v[4 * (size_t)i + a] >= c->pending[a])
                return vox_fail(c, VW_ERROR_FORMAT, r->pos + 4 * (size_t)i,
                                "voxel %d at (%u, %u, %u) lies outside the model size %dx%dx%d", (int)i, v[4 * (size_t)i],
                                v[4 * (size_t)i + 1], v[4 * (size_t)i + 2], (int)c->pending[0], (int)c->pending[1],
                                (int)c->pending[2]);
    }
    if (!grow((void **)&c->models, &c->model_cap, c->model_count, sizeof *c->models))
        return oom(c, at);
    vox_model *m = &c->models[c->model_count++];
    memcpy(m->size, c->pending, sizeof m->size);
    m->count = (uint32_t)n;
    m->solid = solid;
    m->voxels = r->pos;
    c->st.model_voxels += (uint32_t)n;
    int64_t cells = (int64_t)m->size[0] * m->size[1] * m->size[2];
    if (cells > (int64_t)c->st.largest_model[0] * c->st.largest_model[1] * c->st.largest_model[2])
        memcpy(c->st.largest_model, m->size, sizeof m->size);
    return VW_OK;
}

static vw_status read_rgba(vox_ctx *c, vox_reader *r)
{
    if (rd_left(r) < 1024)
        return short_read(c, r, "RGBA", 1024);
    /* Format spec section 7: entry i (0..254) is colour index i + 1; entry 255 is unused. */
    for (int i = 0; i < 255; i++)
        c->palette[i + 1] = le32(r->data + r->pos + 4 * (size_t)i);
    c->palette[0] = 0;
    c->st.has_palette = 1;
    return VW_OK;
}

/* MATL (extension spec (4)) to our flags. See-through: _glass, _cloud and _media always
 * (light passes through them); _blend only when it is transparent (_trans or _alpha > 0):
 * MagicaVoxel writes _blend for plain mixes too, and a _blend without transparency is as
 * opaque as _diffuse. Reflective (and opaque): a mirror-like metal, that is _metal, or a
 * _blend whose _metal is >= 0.5, with _rough given and <= 0.2. A "_vw_flags" key (written by
 * vox_write.c) states our flags exactly and wins, so that our own files round-trip. */
static vw_status read_matl(vox_ctx *c, vox_reader *r)
{
    int32_t id;
    if (!rd_i32(r, &id))
        return short_read(c, r, "the MATL id", 4);
    static const char *const keys[] = {"_type", "_trans", "_alpha", "_rough", "_metal", "_weight", "_vw_flags"};
    vox_str v[7];
    vw_status s = rd_dict(c, r, keys, v, 7);
    if (s != VW_OK)
        return s;
    /* Material ids are colour indices; files number them 0..255 or 1..256 (256 and 0 both
     * mean the unused slot 0). Anything else names no colour: ignore it. */
    if (id < 1 || id > 255)
        return VW_OK;
    double trans = 0.0, alpha = 0.0, rough = 1.0, metal = 0.0, weight = 1.0;
    int has_rough = v[3].p && parse_real(v[3], &rough);
    parse_real(v[1], &trans);
    parse_real(v[2], &alpha);
    int is_metal = str_is(v[0], "_metal"), is_blend = str_is(v[0], "_blend");
    /* Metalness: _metal; for a _metal type without it, the older _weight, else full. */
    if (!(v[4].p && parse_real(v[4], &metal)) && is_metal)
        metal = v[5].p && parse_real(v[5], &weight) ? weight : 1.0;
    uint32_t f = VW_MAT_OPAQUE;
    if (str_is(v[0], "_glass") || str_is(v[0], "_cloud") || str_is(v[0], "_media") ||
        (is_blend && (trans > 0.0 || alpha > 0.0)))
        f = VW_MAT_SEE_THROUGH;
    if ((is_metal || is_blend) && metal >= 0.5 && has_rough && rough <= 0.2)
        f |= VW_MAT_REFLECTIVE;
    int64_t exact;
    if (v[6].p && parse_ints(v[6], 1, 1, 7, &exact) && (exact == VW_MAT_OPAQUE || exact == VW_MAT_SEE_THROUGH ||
                                                          exact == (VW_MAT_OPAQUE | VW_MAT_REFLECTIVE) ||
                                                          exact == (VW_MAT_SEE_THROUGH | VW_MAT_REFLECTIVE)))
        f = (uint32_t)exact;
    c->flags[id] = f;
    return VW_OK;
}

/* MATT, the older material chunk (format spec section 9): type 2 is glass; a metal (type 1)
 * with a roughness property <= 0.2 is a mirror. */
static vw_status read_matt(vox_ctx *c, vox_reader *r)
{
    int32_t id, type;
    float weight, value;
    uint32_t bits;
    if (!rd_i32(r, &id) || !rd_i32(r, &type) || !rd_f32(r, &weight) || !rd_u32(r, &bits))
        return short_read(c, r, "MATT", 16);
    int has_rough = 0;
    float rough = 1.0f;
    /* One float per property bit 0..6 (bit 7, isTotalPower, has no value). */
    for (int b = 0; b < 7; b++) {
        if (!(bits >> b & 1))
            continue;
        if (!rd_f32(r, &value))
            return short_read(c, r, "a MATT property", 4);
        if (b == 1)
            has_rough = 1, rough = value;
    }
    if (id < 1 || id > 255)
        return VW_OK;
    uint32_t f = VW_MAT_OPAQUE;
    if (type == 2)
        f = VW_MAT_SEE_THROUGH;
    else if (type == 1 && has_rough && rough <= 0.2f)
        f |= VW_MAT_REFLECTIVE;
    c->flags[id] = f;
    return VW_OK;
}

static vw_status new_node(vox_ctx *c, vox_reader *r, uint8_t type, vox_node **out)
{
    size_t at = r->pos;
    int32_t id;
    if (!rd_i32(r, &id))
        return short_read(c, r, "the node id", 4);
    if (id < 0)
        return vox_fail(c, VW_ERROR_FORMAT, at, "negative node id %d", (int)id);
    if (!grow((void **)&c->nodes, &c->node_cap, c->node_count, sizeof *c->nodes))
        return oom(c, at);
    vox_node *n = &c->nodes[c->node_count++];
    memset(n, 0, sizeof *n);
    n->id = id;
    n->type = type;
    n->rot = rot_identity;
    n->child = -1;
    n->layer = -1;
    n->model = -1;
    n->chunk = c->chunk_off;
    static const char *const keys[] = {"_hidden"};
    vox_str v[1];
    vw_status s = rd_dict(c, r, keys, v, 1);
    if (s != VW_OK)
        return s;
    n->hidden = (uint8_t)str_is(v[0], "1");
    *out = n;
    return VW_OK;
}

/* The frame index of an animation key (_f); 0 when absent. */
static vw_status frame_index(vox_ctx *c, size_t at, vox_str f, int64_t *out)
{
    *out = 0;
    if (f.p && !parse_ints(f, 1, 0, INT32_MAX, out))
        return vox_fail(c, VW_ERROR_FORMAT, at, "bad frame index _f \"%.*s\"", (int)(f.n > 32 ? 32 : f.n),
                        (const char *)f.p);
    return VW_OK;
}

static vw_status read_ntrn(vox_ctx *c, vox_reader *r)
{
    vox_node *n;
    vw_status s = new_node(c, r, NODE_TRN, &n);
    if (s != VW_OK)
        return s;
    int32_t reserved, frames;
    if (!rd_i32(r, &n->child) || !rd_i32(r, &reserved) || !rd_i32(r, &n->layer))
        return short_read(c, r, "nTRN", 12);
    size_t at = r->pos;
    if (!rd_i32(r, &frames))
        return short_read(c, r, "the nTRN frame count", 4);
    if (frames < 0)
        return vox_fail(c, VW_ERROR_FORMAT, at, "negative nTRN frame count %d", (int)frames);
    if ((size_t)frames > rd_left(r) / 4)
        return vox_fail(c, VW_ERROR_FORMAT, at, "nTRN frame count %d cannot fit in the %zu bytes left", (int)frames,
                        rd_left(r));
    /* Animated transforms (_f keys) are sampled at frame 0: the key with the smallest _f
     * holds from frame 0 until the next key. A plain transform has one frame without _f. */
    int64_t best_f = INT64_MAX;
    for (int32_t i = 0; i < frames; i++) {
        static const char *const keys[] = {"_r", "_t", "_f"};
        vox_str v[3];
        size_t fat = r->pos;
        s = rd_dict(c, r, keys, v, 3);
        if (s != VW_OK)
            return s;
        int64_t f, bits = 4, t[3] = {0, 0, 0};
        vox_rot rot = rot_identity;
        if ((s = frame_index(c, fat, v[2], &f)) != VW_OK)
            return s;
        if (v[0].p && (!parse_ints(v[0], 1, 0, 127, &bits) || !rot_decode(bits, &rot)))
            return vox_fail(c, VW_ERROR_FORMAT, fat, "bad rotation _r \"%.*s\"", (int)(v[0].n > 32 ? 32 : v[0].n),
                            (const char *)v[0].p);
        if (v[1].p && !parse_ints(v[1], 3, INT32_MIN, INT32_MAX, t))
            return vox_fail(c, VW_ERROR_FORMAT, fat, "bad translation _t \"%.*s\"", (int)(v[1].n > 48 ? 48 : v[1].n),
                            (const char *)v[1].p);
        if (f < best_f) {
            best_f = f;
            n->rot = rot;
            for (int a = 0; a < 3; a++)
                n->t[a] = (int32_t)t[a];
        }
    }
    n->rotated = !rot_is_identity(&n->rot);
    c->st.nodes[0]++;
    return VW_OK;
}

static vw_status read_ngrp(vox_ctx *c, vox_reader *r)
{
    vox_node *n;
    vw_status s = new_node(c, r, NODE_GRP, &n);
    if (s != VW_OK)
        return s;
    size_t at = r->pos;
    int32_t count;
    if (!rd_i32(r, &count))
        return short_read(c, r, "the nGRP child count", 4);
    if (count < 0)
        return vox_fail(c, VW_ERROR_FORMAT, at, "negative nGRP child count %d", (int)count);
    if ((size_t)count > rd_left(r) / 4)
        return vox_fail(c, VW_ERROR_FORMAT, at, "nGRP child count %d needs %llu bytes but the chunk has %zu",
                        (int)count, (unsigned long long)count * 4u, rd_left(r));
    n->child_count = (uint32_t)count;
    n->children = r->pos;
    r->pos += 4 * (size_t)count;
    c->st.nodes[1]++;
    return VW_OK;
}

static vw_status read_nshp(vox_ctx *c, vox_reader *r)
{
    vox_node *n;
    vw_status s = new_node(c, r, NODE_SHP, &n);
    if (s != VW_OK)
        return s;
    size_t at = r->pos;
    int32_t count;
    if (!rd_i32(r, &count))
        return short_read(c, r, "the nSHP model count", 4);
    if (count < 0)
        return vox_fail(c, VW_ERROR_FORMAT, at, "negative nSHP model count %d", (int)count);
    if ((size_t)count > rd_left(r) / 8)
        return vox_fail(c, VW_ERROR_FORMAT, at, "nSHP model count %d cannot fit in the %zu bytes left", (int)count,
                        rd_left(r));
    /* Spec: "num of models (must be 1)"; animated shapes list one model per key (_f).
     * Frame 0 shows the one with the smallest _f. */
    int64_t best_f = INT64_MAX;
    for (int32_t i = 0; i < count; i++) {
        size_t mat = r->pos;
        int32_t model;
        if (!rd_i32(r, &model))
            return short_read(c, r, "an nSHP model id", 4);
        if (model < 0)
            return vox_fail(c, VW_ERROR_FORMAT, mat, "negative model id %d", (int)model);
        static const char *const keys[] = {"_f"};
        vox_str v[1];
        if ((s = rd_dict(c, r, keys, v, 1)) != VW_OK)
            return s;
        int64_t f;
        if ((s = frame_index(c, mat, v[0], &f)) != VW_OK)
            return s;
        if (f < best_f)
            best_f = f, n->model = model;
    }
    c->st.nodes[2]++;
    return VW_OK;
}

static vw_status read_layr(vox_ctx *c, vox_reader *r)
{
    size_t at = r->pos;
    int32_t id;
    if (!rd_i32(r, &id))
        return short_read(c, r, "the LAYR id", 4);
    static const char *const keys[] = {"_hidden"};
    vox_str v[1];
    vw_status s = rd_dict(c, r, keys, v, 1);
    if (s != VW_OK)
        return s;
    /* The trailing reserved int32 (-1) is not needed; older writers omit it. */
    if (!grow((void **)&c->layers, &c->layer_cap, c->layer_count, sizeof *c->layers))
        return oom(c, at);
    c->layers[c->layer_count].id = id;
    c->layers[c->layer_count].hidden = (uint8_t)str_is(v[0], "1");
    c->layers[c->layer_count].order = c->layer_count;
    c->layer_count++;
    c->st.layers++;
    return VW_OK;
}

static vw_status read_imap(vox_ctx *c, vox_reader *r)
{
    if (rd_left(r) < 256)
        return short_read(c, r, "IMAP", 256);
    memcpy(c->imap, r->data + r->pos, 256);
    c->has_imap = 1;
    return VW_OK;
}

/* Walks MAIN's children (format spec section 2: id, N, M, N bytes of content, M bytes of
 * children). Chunks we do not use (rOBJ, rCAM, NOTE, PACK's count, and any future chunk)
 * are skipped by their sizes, which are checked like every other. */
static vw_status read_chunks(vox_ctx *c, size_t pos, size_t end)
{
    while (pos < end) {
        if (end - pos < 12) {
            c->chunk_id = ID_MAIN;
            c->chunk_off = 8;
            return vox_fail(c, VW_ERROR_FORMAT, pos, "truncated child chunk header: %zu of 12 bytes", end - pos);
        }
        uint32_t id = le32(c->data + pos), n = le32(c->data + pos + 4), m = le32(c->data + pos + 8);
        c->chunk_id = id ? id : 0x3F3F3F3Fu;
        c->chunk_off = pos;
        if (n > 0x7FFFFFFFu || m > 0x7FFFFFFFu)
            return vox_fail(c, VW_ERROR_FORMAT, pos + (n > 0x7FFFFFFFu ? 4 : 8), "negative chunk size %d",
                            (int)(n > 0x7FFFFFFFu ? (int32_t)(n - 0x80000000u) - 0x7FFFFFFF - 1
                                                  : (int32_t)(m - 0x80000000u) - 0x7FFFFFFF - 1));
        size_t left = end - pos - 12;
        if ((size_t)n > left || (size_t)m > left - n)
            return vox_fail(c, VW_ERROR_FORMAT, pos + 4,
                            "chunk content %u + children %u bytes run past the end of their parent (%zu bytes left)",
                            (unsigned)n, (unsigned)m, left);
        vox_reader r = {c->data, pos + 12, pos + 12 + n};
        vw_status s = VW_OK;
        switch (id) {
        case ID_PACK: {
            int32_t models;
            if (!rd_i32(&r, &models))
                s = short_read(c, &r, "PACK", 4);
            else if (models < 0)
                s = vox_fail(c, VW_ERROR_FORMAT, pos + 12, "negative PACK model count %d", (int)models);
            break;
        }
        case ID_SIZE: s = read_size(c, &r); break;
        case ID_XYZI: s = read_xyzi(c, &r); break;
        case ID_RGBA: s = read_rgba(c, &r); break;
        case ID_MATL: s = read_matl(c, &r); break;
        case ID_MATT: s = read_matt(c, &r); break;
        case ID_nTRN: s = read_ntrn(c, &r); break;
        case ID_nGRP: s = read_ngrp(c, &r); break;
        case ID_nSHP: s = read_nshp(c, &r); break;
        case ID_LAYR: s = read_layr(c, &r); break;
        case ID_IMAP: s = read_imap(c, &r); break;
        default: break;
        }
        if (s != VW_OK)
            return s;
        /* Children of chunks other than MAIN are not defined by the spec: skipped. */
        pos += 12 + (size_t)n + (size_t)m;
    }
    c->chunk_id = 0;
    return VW_OK;
}

/* ---- the scene graph ---------------------------------------------------------------- */

static int node_cmp(const void *a, const void *b)
{
    const vox_node *x = a, *y = b;
    if (x->id != y->id)
        return x->id < y->id ? -1 : 1;
    return x->chunk < y->chunk ? -1 : x->chunk > y->chunk;
}

/* Index of node `id` in the sorted array, or -1. */
static int64_t find_node(const vox_ctx *c, int32_t id)
{
    uint32_t lo = 0, hi = c->node_count;
    while (lo < hi) {
        uint32_t mid = lo + (hi - lo) / 2;
        if (c->nodes[mid].id < id)
            lo = mid + 1;
        else
            hi = mid;
    }
    return lo < c->node_count && c->nodes[lo].id == id ? (int64_t)lo : -1;
}

static int layer_cmp(const void *a, const void *b)
{
    const vox_layer *x = a, *y = b;
    if (x->id != y->id)
        return x->id < y->id ? -1 : 1;
    return x->order < y->order ? -1 : x->order > y->order;
}

/* Whether layer `id` is hidden, in the sorted array (the last LAYR of an id wins). Sorted
 * once and looked up once per transform node, so that many layers times a wide DAG cannot
 * multiply into a hang. */
static int layer_hidden(const vox_ctx *c, int32_t id)
{
    uint32_t lo = 0, hi = c->layer_count;
    while (lo < hi) {
        uint32_t mid = lo + (hi - lo) / 2;
        if (c->layers[mid].id <= id)
            lo = mid + 1;
        else
            hi = mid;
    }
    return id >= 0 && lo > 0 && c->layers[lo - 1].id == id && c->layers[lo - 1].hidden;
}

/* Checks every reference before the walk: children, models, and duplicates. A transform in
 * a hidden layer becomes a hidden node here, so the walk looks at nodes only. */
static vw_status check_graph(vox_ctx *c)
{
    /* (qsort's array may not be NULL even for 0 elements: files without LAYR have none.) */
    if (c->node_count > 1)
        qsort(c->nodes, c->node_count, sizeof *c->nodes, node_cmp);
    if (c->layer_count > 1)
        qsort(c->layers, c->layer_count, sizeof *c->layers, layer_cmp);
    for (uint32_t i = 0; i < c->node_count; i++) {
        vox_node *n = &c->nodes[i];
        if (n->type == NODE_TRN && layer_hidden(c, n->layer))
            n->hidden = 1;
        c->chunk_id = n->type == NODE_TRN ? ID_nTRN : n->type == NODE_GRP ? ID_nGRP : ID_nSHP;
        c->chunk_off = n->chunk;
        if (i > 0 && c->nodes[i - 1].id == n->id)
            return vox_fail(c, VW_ERROR_FORMAT, n->chunk + 12, "node id %d is used twice (also at byte offset %zu)",
                            (int)n->id, c->nodes[i - 1].chunk);
        if (n->type == NODE_TRN && find_node(c, n->child) < 0)
            return vox_fail(c, VW_ERROR_FORMAT, n->chunk + 12, "node %d refers to missing child node %d", (int)n->id,
                            (int)n->child);
        if (n->type == NODE_SHP && n->model >= 0 && (uint32_t)n->model >= c->model_count)
            return vox_fail(c, VW_ERROR_FORMAT, n->chunk + 12, "shape node %d refers to missing model %d (%u models)",
                            (int)n->id, (int)n->model, (unsigned)c->model_count);
        if (n->type == NODE_GRP)
            for (uint32_t k = 0; k < n->child_count; k++) {
                size_t at = n->children + 4 * (size_t)k;
                vox_reader r = {c->data, at, at + 4};
                int32_t child;
                rd_i32(&r, &child);
                if (find_node(c, child) < 0)
                    return vox_fail(c, VW_ERROR_FORMAT, at, "group node %d refers to missing child node %d",
                                    (int)n->id, (int)child);
            }
    }
    c->chunk_id = 0;
    if (c->node_count && find_node(c, 0) < 0) {
        c->chunk_id = ID_nTRN;
        c->chunk_off = c->nodes[0].chunk;
        return vox_fail(c, VW_ERROR_FORMAT, c->nodes[0].chunk, "the scene graph has no root node 0");
    }
    return VW_OK;
}

static vw_status add_instance(vox_ctx *c, uint32_t model, const vox_rot *rot, const int64_t t[3], size_t at)
{
    if (c->inst_count >= c->lim.max_instances)
        return vox_fail(c, VW_ERROR_FORMAT, at, "more than %u instances", (unsigned)c->lim.max_instances);
    c->st.instanced_voxels += c->models[model].count;
    c->instanced_solid += c->models[model].solid;
    if (c->building && c->instanced_solid > c->budget.max_voxels) {
        char n1[32], n2[32];
        return vwi_fail(c->err, VW_ERROR_BUDGET,
                        ".vox: the first %u instances already hold %s solid voxels; the budget is %s voxels",
                        (unsigned)(c->inst_count + 1), vwi_format_count(c->instanced_solid, n2, sizeof n2),
                        vwi_format_count(c->budget.max_voxels, n1, sizeof n1));
    }
    if (c->st.instanced_voxels > c->lim.max_instanced_voxels)
        return vox_fail(c, VW_ERROR_FORMAT, at, "instances hold more than %llu voxels",
                        (unsigned long long)c->lim.max_instanced_voxels);
    if (!grow((void **)&c->inst, &c->inst_cap, c->inst_count, sizeof *c->inst))
        return oom(c, at);
    vox_inst *in = &c->inst[c->inst_count++];
    in->model = model;
    in->rot = *rot;
    memcpy(in->t, t, sizeof in->t);
    in->chunk_id = c->chunk_id;
    in->chunk = c->chunk_off;
    c->st.instances++;
    return VW_OK;
}

typedef struct vox_frame {
    uint32_t node;
    uint32_t next;   /* next child to visit                                               */
    uint8_t hidden;
    vox_rot rot;     /* accumulated, this node included                                   */
    int64_t t[3];
} vox_frame;

/* Expands the scene graph into instances: a depth-first walk from node 0 in which every
 * path is an instance (a group shared by several parents is visited once per parent).
 * Transforms compose as in the extension spec (d) and ogt_vox: parent * child, so
 * R = R_parent R_node and t = t_parent + R_parent t_node. */
static vw_status expand_graph(vox_ctx *c)
{
    vw_status s = VW_OK;
    vox_frame *stack = malloc(((size_t)c->node_count + 1) * sizeof *stack);
    uint8_t *on_path = calloc(c->node_count, 1);
    if (!stack || !on_path) {
        free(stack);
        free(on_path);
        return oom(c, 0);
    }
    uint64_t visits = 0;
    size_t depth = 0;
    int64_t origin[3] = {0, 0, 0};
    uint32_t next = (uint32_t)find_node(c, 0);
    const vox_rot *prot = &rot_identity;
    const int64_t *pt = origin;
    uint8_t phidden = 0;
    for (;;) {
        if (next != UINT32_MAX) {
            /* Enter node `next` below the top frame (or as the root). */
            const vox_node *n = &c->nodes[next];
            c->chunk_id = n->type == NODE_TRN ? ID_nTRN : n->type == NODE_GRP ? ID_nGRP : ID_nSHP;
            c->chunk_off = n->chunk;
            if (on_path[next]) {
                s = vox_fail(c, VW_ERROR_FORMAT, n->chunk + 12, "loop in the scene graph: node %d is its own ancestor",
                             (int)n->id);
                break;
            }
            if (++visits > c->lim.max_node_visits) {
                s = vox_fail(c, VW_ERROR_FORMAT, n->chunk + 12, "scene graph expands to more than %u node visits",
                             (unsigned)c->lim.max_node_visits);
                break;
            }
            vox_frame *f = &stack[depth++];
            on_path[next] = 1;
            f->node = next;
            f->next = 0;
            f->hidden = (uint8_t)(phidden | n->hidden);
            f->rot = *prot;
            memcpy(f->t, pt, sizeof f->t);
            if (n->type == NODE_TRN) {
                for (int i = 0; i < 3; i++) {
                    f->t[i] = pt[i] + (int64_t)prot->sign[i] * n->t[prot->col[i]];
                    if (f->t[i] > VOX_MAX_COORD || f->t[i] < -VOX_MAX_COORD) {
                        s = vox_fail(c, VW_ERROR_FORMAT, n->chunk + 12, "translations add up beyond 2^58");
                        break;
                    }
                }
                if (s != VW_OK)
                    break;
                f->rot = rot_mul(prot, &n->rot);
                c->st.rotated_transforms += n->rotated;
            } else if (n->type == NODE_SHP && n->model >= 0) {
                if (f->hidden)
                    c->st.hidden_instances++;
                else if ((s = add_instance(c, (uint32_t)n->model, &f->rot, f->t, n->chunk)) != VW_OK)
                    break;
            }
        }
        if (depth == 0)
            break;
        /* Pick the next child of the top frame, or pop it. */
        vox_frame *f = &stack[depth - 1];
        const vox_node *n = &c->nodes[f->node];
        next = UINT32_MAX;
        if (n->type == NODE_TRN && f->next == 0) {
            f->next = 1;
            next = (uint32_t)find_node(c, n->child);
        } else if (n->type == NODE_GRP && f->next < n->child_count) {
            size_t at = n->children + 4 * (size_t)f->next++;
            vox_reader r = {c->data, at, at + 4};
            int32_t child;
            rd_i32(&r, &child);
            next = (uint32_t)find_node(c, child);
        }
        if (next == UINT32_MAX) {
            on_path[f->node] = 0;
            depth--;
        } else {
            prot = &f->rot;
            pt = f->t;
            phidden = f->hidden;
        }
    }
    c->chunk_id = 0;
    free(stack);
    free(on_path);
    return s;
}

/* ---- placement ---------------------------------------------------------------------- */

/* The .vox cell of model voxel p under (R, t): floor(R (p + 0.5 - h) + t), h = floor(size/2),
 * in integers. Row i picks p[j], j = col[i]: +(p - h) when the sign is +, and -(p - h) - 1
 * when it is -, since the cell [p, p+1] flips to [-p-1, -p]. */
static void place(const vox_inst *in, const int32_t size[3], const int64_t p[3], int64_t q[3])
{
    for (int i = 0; i < 3; i++) {
        int j = in->rot.col[i];
        int64_t d = p[j] - size[j] / 2;
        q[i] = in->t[i] + (in->rot.sign[i] > 0 ? d : -d - 1);
    }
}

/* .vox (x, y, z), z up, to the world's Y-up right-handed axes: the cell [x,x+1]x[y,y+1]x[z,z+1]
 * becomes [x,x+1]x[z,z+1]x[-y-1,-y] (vw.h). */
static void to_world(const int64_t q[3], int64_t w[3])
{
    w[0] = q[0];
    w[1] = q[2];
    w[2] = -q[1] - 1;
}

/* The instance's model box in world coordinates, [lo, hi). */
static void instance_box(const vox_ctx *c, const vox_inst *in, int64_t lo[3], int64_t hi[3])
{
    const vox_model *m = &c->models[in->model];
    const int64_t p0[3] = {0, 0, 0}, p1[3] = {m->size[0] - 1, m->size[1] - 1, m->size[2] - 1};
    int64_t q0[3], q1[3], w0[3], w1[3];
    place(in, m->size, p0, q0);
    place(in, m->size, p1, q1);
    to_world(q0, w0);
    to_world(q1, w1);
    for (int a = 0; a < 3; a++) {
        lo[a] = w0[a] < w1[a] ? w0[a] : w1[a];
        hi[a] = (w0[a] > w1[a] ? w0[a] : w1[a]) + 1;
    }
}

static int64_t floor_div(int64_t a, int64_t b) { return a >= 0 ? a / b : -((-a + b - 1) / b); }

/* The colour index a voxel of colour c gets in the world. IMAP (extension spec (9)) lists,
 * for each palette slot k in MagicaVoxel's display order, the colour index shown there;
 * like ogt_vox we renumber colours into display order (slot k becomes index k + 1, the last
 * slot index 0), so material indices match what the artist sees. It only renumbers: a
 * voxel keeps its colour and material either way, so an IMAP that is not a permutation
 * keeping 0 empty is ignored. */
static int index_map(const vox_ctx *c, uint8_t out[256])
{
    for (int i = 0; i < 256; i++)
        out[i] = (uint8_t)i;
    if (!c->has_imap || c->imap[255] != 0)
        return 0;
    uint8_t seen[256] = {0};
    uint8_t map[256];
    for (int k = 0; k < 256; k++) {
        if (seen[c->imap[k]]++)
            return 0;
        map[c->imap[k]] = (uint8_t)((k + 1) & 255);
    }
    memcpy(out, map, sizeof map);
    return 1;
}

/* The budget against the world build_world is about to make (origin, chunk counts n):
 * its table, and a dense chunk for every distinct chunk a solid instanced voxel lands in
 * (vw_world_set makes each dense on its first voxel and compacts it only when it fills up
 * with one material, so this bounds the peak). The touched chunks are counted exactly, one bit per
 * chunk of the table, which max_chunks bounds (512 KiB by default, and never more than a
 * 128th of the table, which is checked first). */
static vw_status check_budget(vox_ctx *c, const int64_t origin[3], const int32_t n[3], uint64_t chunks, int32_t chunk_size)
{
    char b1[32], b2[32], b3[32], n1[32];
    const uint64_t table = vwi_table_bytes(chunks), limit = c->budget.max_bytes;
    if (table > limit)
        return vwi_fail(c->err, VW_ERROR_BUDGET, ".vox: the scene spans %s chunks, whose table needs %s; the budget is %s",
                        vwi_format_count(chunks, n1, sizeof n1), vwi_format_bytes(table, b1, sizeof b1),
                        vwi_format_bytes(limit, b2, sizeof b2));
    uint64_t *seen = calloc((size_t)((chunks + 63) / 64), sizeof *seen);
    if (!seen)
        return vwi_fail(c->err, VW_ERROR_OUT_OF_MEMORY, ".vox: out of memory for a bit per chunk (%s chunks)",
                        vwi_format_count(chunks, n1, sizeof n1));
    const int shift = chunk_size == 16 ? 4 : 5;
    uint64_t dense = 0;
    for (uint32_t i = 0; i < c->inst_count; i++) {
        const vox_inst *in = &c->inst[i];
        const vox_model *m = &c->models[in->model];
        const uint8_t *v = c->data + m->voxels;
        for (uint32_t k = 0; k < m->count; k++, v += 4) {
            if (v[3] == 0)
                continue;
            const int64_t p[3] = {v[0], v[1], v[2]};
            int64_t q[3], wp[3];
            place(in, m->size, p, q);
            to_world(q, wp);
            /* Inside the world by construction (it covers every instance box). */
            uint64_t idx = 0;
            for (int a = 2; a >= 0; a--)
                idx = idx * (uint64_t)n[a] + (uint64_t)((wp[a] - origin[a]) >> shift);
            const uint64_t bit = 1ull << (idx & 63);
            if (!(seen[idx >> 6] & bit)) {
                seen[idx >> 6] |= bit;
                dense++;
            }
        }
    }
    free(seen);
    const uint64_t vol = (uint64_t)chunk_size * (uint64_t)chunk_size * (uint64_t)chunk_size;
    if (table + dense * vol > limit)
        return vwi_fail(c->err, VW_ERROR_BUDGET,
                        ".vox: the scene needs %s for %s dense chunks (the chunks its voxels land in), and %s for its "
                        "table; the budget is %s",
                        vwi_format_bytes(dense * vol, b1, sizeof b1), vwi_format_count(dense, n1, sizeof n1),
                        vwi_format_bytes(table, b2, sizeof b2), vwi_format_bytes(limit, b3, sizeof b3));
    return VW_OK;
}

static vw_status build_world(vox_ctx *c, int32_t chunk_size, vw_world **out_world)
{
    int64_t lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0};
    uint32_t at_max[3] = {0, 0, 0}; /* the instance reaching furthest, named on errors */
    for (uint32_t i = 0; i < c->inst_count; i++) {
        int64_t a[3], b[3];
        instance_box(c, &c->inst[i], a, b);
        for (int k = 0; k < 3; k++) {
            if (i == 0 || a[k] < lo[k])
                lo[k] = a[k];
            if (i == 0 || b[k] > hi[k])
                hi[k] = b[k], at_max[k] = i;
        }
    }
    memcpy(c->st.bounds_min, lo, sizeof lo);
    memcpy(c->st.bounds_max, hi, sizeof hi);
    uint8_t map[256];
    c->st.has_index_map = index_map(c, map);

    /* The world: origin at the boxes' min corner rounded down to a chunk, size to cover
     * every box. An empty scene gives one empty chunk at 0. */
    vw_world_desc desc;
    memset(&desc, 0, sizeof desc);
    desc.chunk_size = chunk_size;
    desc.max_bytes = c->budget.max_bytes;
    uint64_t chunks = 1;
    int32_t n[3];
    for (int a = 0; a < 3; a++) {
        desc.origin[a] = floor_div(lo[a], chunk_size) * chunk_size;
        int64_t extent = hi[a] - desc.origin[a];
        if (extent < 1)
            extent = 1;
        if (extent > VOX_MAX_AXIS) {
            c->chunk_id = c->inst[at_max[a]].chunk_id;
            c->chunk_off = c->inst[at_max[a]].chunk;
            return vox_fail(c, VW_ERROR_FORMAT, c->chunk_off,
                            "the scene spans %lld voxels along world axis %c (at most %lld) up to this instance",
                            (long long)extent, "xyz"[a], (long long)VOX_MAX_AXIS);
        }
        desc.size[a] = (int32_t)extent;
        n[a] = (int32_t)((extent + chunk_size - 1) / chunk_size);
        chunks *= (uint64_t)n[a];
    }
    if (chunks > c->lim.max_chunks) {
        c->chunk_id = c->inst[at_max[0]].chunk_id;
        c->chunk_off = c->inst[at_max[0]].chunk;
        return vox_fail(c, VW_ERROR_FORMAT, c->chunk_off,
                        "the scene spans %dx%dx%d voxels, %llu chunks (at most %u), up to this instance", desc.size[0],
                        desc.size[1], desc.size[2], (unsigned long long)chunks, (unsigned)c->lim.max_chunks);
    }
    if (!out_world)
        return VW_OK;
    vw_status s = check_budget(c, desc.origin, n, chunks, chunk_size);
    if (s != VW_OK)
        return s;

    vw_world *w = NULL;
    s = vw_world_create(&desc, &w, c->err);
    if (s != VW_OK)
        return s;
    /* Materials before voxels: changing flags marks chunks with voxels dirty. */
    for (uint32_t i = 1; i < 256; i++) {
        vw_material m = {c->palette[i], c->flags[i]};
        vw_world_set_material(w, map[i], &m);
    }
    for (uint32_t i = 0; i < c->inst_count && s == VW_OK; i++) {
        const vox_inst *in = &c->inst[i];
        const vox_model *m = &c->models[in->model];
        const uint8_t *v = c->data + m->voxels;
        for (uint32_t k = 0; k < m->count; k++, v += 4) {
            if (v[3] == 0)
                continue; /* colour 0 is empty */
            const int64_t p[3] = {v[0], v[1], v[2]};
            int64_t q[3], wp[3];
            place(in, m->size, p, q);
            to_world(q, wp);
            s = vw_world_set(w, wp[0], wp[1], wp[2], map[v[3]]);
            if (s != VW_OK) {
                s = vox_fail(c, s, m->voxels + 4 * (size_t)k, "could not store a voxel (%s)", vw_status_string(s));
                break;
            }
        }
    }
    if (s != VW_OK) {
        vw_world_destroy(w);
        return s;
    }
    /* A loaded world starts clean: its user meshes every chunk once. */
    vw_world_clear_dirty(w);
    *out_world = w;
    return VW_OK;
}

/* ---- entry points ------------------------------------------------------------------- */

static vw_status load(const void *data, size_t size, int32_t chunk_size, const vw_vox_limits *limits,
                      const vw_budget *budget, vw_world **out_world, vw_vox_stats *out_stats, vw_error *err)
{
    if (out_world)
        *out_world = NULL;
    if (out_stats)
        memset(out_stats, 0, sizeof *out_stats);
    if (err)
        err->message[0] = 0;
    if (!data && size)
        return VW_ERROR_INVALID_ARGUMENT;
    if (chunk_size == 0)
        chunk_size = 16;
    if (chunk_size != 16 && chunk_size != 32) {
        if (err)
            snprintf(err->message, sizeof err->message, "chunk size %d: must be 16 or 32", (int)chunk_size);
        return VW_ERROR_INVALID_ARGUMENT;
    }

    vox_ctx *c = calloc(1, sizeof *c);
    if (!c)
        return VW_ERROR_OUT_OF_MEMORY;
    c->data = data;
    c->size = size;
    c->err = err;
    c->lim.max_chunks = limits && limits->max_chunks ? limits->max_chunks : 1u << 22;
    c->lim.max_instances = limits && limits->max_instances ? limits->max_instances : 1u << 18;
    c->lim.max_instanced_voxels = limits && limits->max_instanced_voxels ? limits->max_instanced_voxels : 1ull << 28;
    c->lim.max_node_visits = limits && limits->max_node_visits ? limits->max_node_visits : 1u << 24;
    c->budget = vwi_budget(budget);
    c->building = out_world != NULL;
    memcpy(c->palette, vw_vox_default_palette, sizeof c->palette);
    for (int i = 0; i < 256; i++)
        c->flags[i] = VW_MAT_OPAQUE;

    vw_status s = VW_OK;
    const uint8_t *p = data;
    if (size < 8) {
        s = vox_fail(c, VW_ERROR_FORMAT, 0, "file of %zu bytes is too short for the 8-byte header", size);
    } else if (le32(p) != ID_VOX) {
        s = vox_fail(c, VW_ERROR_FORMAT, 0, "not a .vox file (no 'VOX ' magic)");
    } else {
        c->st.version = le32(p + 4);
        if (c->st.version != 150 && c->st.version != 200)
            s = vox_fail(c, VW_ERROR_UNSUPPORTED, 4, "version %u is not supported (150 and 200 are)",
                         (unsigned)c->st.version);
    }
    if (s == VW_OK) {
        /* MAIN: no content of its own (N is skipped if present); its children are the file. */
        c->chunk_id = ID_MAIN;
        c->chunk_off = 8;
        if (size - 8 < 12)
            s = vox_fail(c, VW_ERROR_FORMAT, 8, "truncated MAIN chunk header: %zu of 12 bytes", size - 8);
        else if (le32(p + 8) != ID_MAIN)
            s = vox_fail(c, VW_ERROR_FORMAT, 8, "the first chunk is not MAIN");
        else {
            uint32_t n = le32(p + 12), m = le32(p + 16);
            size_t left = size - 20;
            if (n > 0x7FFFFFFFu || m > 0x7FFFFFFFu)
                s = vox_fail(c, VW_ERROR_FORMAT, 12, "negative MAIN size");
            else if ((size_t)n > left || (size_t)m > left - n)
                s = vox_fail(c, VW_ERROR_FORMAT, 12,
                             "MAIN content %u + children %u bytes run past the end of the file (%zu bytes left)",
                             (unsigned)n, (unsigned)m, left);
            else
                s = read_chunks(c, 20 + (size_t)n, 20 + (size_t)n + m); /* trailing bytes are ignored */
        }
    }
    if (s == VW_OK && c->pending_size) {
        c->chunk_id = ID_SIZE;
        c->chunk_off = c->pending_off;
        s = vox_fail(c, VW_ERROR_FORMAT, c->pending_off, "SIZE without its XYZI");
    }
    if (s == VW_OK) {
        c->st.models = c->model_count;
        if (c->node_count) {
            s = check_graph(c);
            if (s == VW_OK)
                s = expand_graph(c);
        } else {
            /* No scene graph (older files): every model once, untransformed, as ogt_vox does. */
            for (uint32_t i = 0; i < c->model_count && s == VW_OK; i++) {
                const int64_t t[3] = {0, 0, 0};
                c->chunk_id = ID_XYZI;
                c->chunk_off = c->models[i].voxels - 16;
                s = add_instance(c, i, &rot_identity, t, c->chunk_off);
            }
            c->chunk_id = 0;
        }
    }
    if (s == VW_OK)
        s = build_world(c, chunk_size, out_world);
    if (out_stats)
        *out_stats = c->st;
    free(c->models);
    free(c->nodes);
    free(c->layers);
    free(c->inst);
    free(c);
    return s;
}

vw_status vw_vox_load_memory_ex(const void *data, size_t size, int32_t chunk_size, const vw_vox_limits *limits,
                                vw_world **out_world, vw_vox_stats *out_stats, vw_error *err)
{
    return load(data, size, chunk_size, limits, NULL, out_world, out_stats, err);
}

vw_status vw_vox_load_memory(const void *data, size_t size, int32_t chunk_size, const vw_budget *budget,
                             vw_world **out_world, vw_error *err)
{
    if (!out_world)
        return VW_ERROR_INVALID_ARGUMENT;
    return load(data, size, chunk_size, NULL, budget, out_world, NULL, err);
}

/* Reads exactly n bytes at the current position; 0 on an error or a short file. */
static int read_full(int fd, uint8_t *buf, size_t n)
{
    while (n > 0) {
        ssize_t got = read(fd, buf, n);
        if (got < 0 && errno == EINTR)
            continue;
        if (got == 0)
            errno = 0; /* the end of the file came first */
        if (got <= 0)
            return 0;
        buf += got;
        n -= (size_t)got;
    }
    return 1;
}

vw_status vw_vox_load_file(const char *path, int32_t chunk_size, const vw_budget *budget, vw_world **out_world,
                           vw_error *err)
{
    if (out_world)
        *out_world = NULL;
    if (!path || !out_world)
        return VW_ERROR_INVALID_ARGUMENT;
    const vw_budget b = vwi_budget(budget);
    /* Non-blocking, so that opening a FIFO returns at once (to be refused below) instead of
     * waiting for a writer; it changes nothing for a regular file. */
    int fd = open(path, O_RDONLY | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0)
        return vwi_fail(err, VW_ERROR_IO, "cannot open %s: %s", path, strerror(errno));
    struct stat st;
    if (fstat(fd, &st) != 0) {
        int e = errno;
        close(fd);
        return vwi_fail(err, VW_ERROR_IO, "cannot stat %s: %s", path, strerror(e));
    }
    if (!S_ISREG(st.st_mode)) {
        close(fd);
        return vwi_fail(err, VW_ERROR_IO, "%s is not a regular file (%s)", path,
                        S_ISFIFO(st.st_mode) ? "a FIFO" : S_ISCHR(st.st_mode) ? "a character device"
                                            : S_ISBLK(st.st_mode)   ? "a block device"
                                            : S_ISDIR(st.st_mode)   ? "a directory"
                                            : S_ISSOCK(st.st_mode)  ? "a socket"
                                                                    : "not a plain file");
    }
    char b1[32], b2[32];
    const uint64_t file_size = st.st_size > 0 ? (uint64_t)st.st_size : 0;
    if (file_size > b.max_bytes || file_size > SIZE_MAX) {
        close(fd);
        return vwi_fail(err, VW_ERROR_BUDGET, "%s: the file's %s are more than the budget of %s", path,
                        vwi_format_bytes(file_size, b1, sizeof b1), vwi_format_bytes(b.max_bytes, b2, sizeof b2));
    }
    /* The header first: the magic, then MAIN's sizes say how much of the file the parser
     * will look at (trailing bytes are ignored), so only that much is read. A file too
     * short for either is read whole (it is tiny) for the parser's own message. */
    uint8_t head[20];
    size_t want = (size_t)file_size, have = 0;
    if (file_size >= 8) {
        if (!read_full(fd, head, 8)) {
            int e = errno;
            close(fd);
            return vwi_fail(err, VW_ERROR_IO, "cannot read %s: %s", path, e ? strerror(e) : "the file shrank");
        }
        have = 8;
        if (memcmp(head, "VOX ", 4) != 0) {
            close(fd);
            return vwi_fail(err, VW_ERROR_FORMAT, ".vox: %s: not a .vox file (no 'VOX ' magic) at byte offset 0 (file header)",
                            path);
        }
        if (file_size >= 20) {
            if (!read_full(fd, head + 8, 12)) {
                int e = errno;
                close(fd);
                return vwi_fail(err, VW_ERROR_IO, "cannot read %s: %s", path, e ? strerror(e) : "the file shrank");
            }
            have = 20;
            const uint64_t claimed = 20 + (uint64_t)(head[12] | head[13] << 8 | head[14] << 16 | (uint32_t)head[15] << 24) +
                                     (uint64_t)(head[16] | head[17] << 8 | head[18] << 16 | (uint32_t)head[19] << 24);
            if (claimed < file_size)
                want = (size_t)claimed; /* a claim past the end is the parser's to report */
        }
    }
    uint8_t *buf = malloc(want ? want : 1);
    if (!buf) {
        close(fd);
        return vwi_fail(err, VW_ERROR_OUT_OF_MEMORY, "out of memory reading %s (%s)", path,
                        vwi_format_bytes(want, b1, sizeof b1));
    }
    memcpy(buf, head, have);
    int ok = read_full(fd, buf + have, want - have);
    int e = errno;
    close(fd);
    vw_status s;
    if (!ok)
        s = vwi_fail(err, VW_ERROR_IO, "cannot read %s: %s", path, e ? strerror(e) : "the file shrank while it was read");
    else
        s = vw_vox_load_memory(buf, want, chunk_size, budget, out_world, err);
    free(buf);
    return s;
}
