/*
 * voxelworld — chunked voxel storage, edits, the greedy chunk mesher, generators, and
 * importers/exporters. It knows nothing of kd-trees or rays: libvis sees only the meshes.
 *
 * Coordinates: integer voxels, Y up. The voxel (x, y, z) fills the cell [x,x+1]x[y,y+1]x[z,z+1].
 * A world is a box of chunks: origin (its minimum voxel, any int64, a multiple of the chunk
 * edge) and size (voxels per axis, a multiple of the chunk edge). Chunks are indexed
 * relative to the origin, so worlds far from (0,0,0) behave exactly like worlds near it.
 *
 * Object IDs: the chunk at chunk coordinates (cx, cy, cz) (relative to the world origin, in
 * chunks) is object ID  1 + cx + nx*(cy + ny*cz)  where (nx, ny, nz) are the world's chunk
 * counts. The ID depends only on where the chunk is, so a world rebuilt from scratch gives
 * every chunk the same ID it had.
 *
 * Thread safety: a world may be read (get, mesh) from several threads at once; writes
 * (set, fill, take_dirty) must not run concurrently with anything else on the same world.
 * Nothing here prints or exits.
 *
 * Threads: vw_world_load and vw_mesh_chunks take a thread count. They start that many
 * threads minus one for the call (the calling thread is the first) and join them before
 * returning; nothing outlives the call, and the results are bit-identical for every count
 * (1 is serial). A thread that cannot be started only makes the call slower.
 */
#ifndef VOXELWORLD_VW_H
#define VOXELWORLD_VW_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef enum vw_status {
    VW_OK = 0,
    VW_ERROR_INVALID_ARGUMENT,
    VW_ERROR_OUT_OF_MEMORY,
    VW_ERROR_IO,          /* a file could not be opened, read or written                  */
    VW_ERROR_FORMAT,      /* a file or buffer is malformed (the message has offset, chunk) */
    VW_ERROR_UNSUPPORTED, /* a feature this build or format version lacks                 */
    VW_ERROR_RANGE,       /* a coordinate outside the world                               */
    VW_ERROR_BUDGET       /* a load, generator or edit would exceed its vw_budget          */
} vw_status;

const char *vw_status_string(vw_status status);

/* Optional detail for a failed call: functions that take a vw_error* (may be NULL) write a
 * human-readable message into it on failure. */
typedef struct vw_error {
    char message[512];
} vw_error;

/* ---- materials ---------------------------------------------------------------------- */

#define VW_MAT_OPAQUE      0x1u  /* blocks rays                                          */
#define VW_MAT_SEE_THROUGH 0x2u  /* glass, water, leaves: rays record it and continue      */
#define VW_MAT_REFLECTIVE  0x4u  /* water, mirrors                                         */

typedef struct vw_material {
    uint32_t rgba;   /* 0xAABBGGRR                                                       */
    uint32_t flags;  /* VW_MAT_*; a material without SEE_THROUGH is opaque                */
} vw_material;

/* Voxel values are material indices: 0 is empty, 1..255 are materials. */
typedef uint8_t vw_voxel;

/* ---- budgets ------------------------------------------------------------------------ */

/* What building a world may cost. Loaders and generators check it arithmetically (from the
 * sizes and counts a file or spec declares) before allocating, and the world enforces
 * max_bytes on every allocation it makes afterwards, so no input can cost more than this.
 * Zero fields mean the defaults. */
#define VW_DEFAULT_MAX_BYTES  ((uint64_t)2 << 30) /* 2 GiB                                   */
#define VW_DEFAULT_MAX_VOXELS ((uint64_t)1 << 30)

typedef struct vw_budget {
    uint64_t max_bytes;  /* memory the world may hold: chunk table, dirty bits, dense chunks
                            (a generated world keeps those in 2 MiB blocks, counted whole)   */
    uint64_t max_voxels; /* voxels a load may write: a generator's whole box, an importer's
                            solid voxels (each instance of a model counted)                 */
} vw_budget;

/* ---- world -------------------------------------------------------------------------- */

typedef struct vw_world vw_world;

typedef struct vw_world_desc {
    int32_t chunk_size;  /* 16 (default when 0) or 32                                        */
    int64_t origin[3];   /* minimum voxel; must be a multiple of chunk_size                  */
    int32_t size[3];     /* voxels per axis, > 0, rounded up to a multiple of chunk_size      */
    uint64_t max_bytes;  /* memory the world may ever hold (vw_world_info.bytes); 0 =
                            VW_DEFAULT_MAX_BYTES. Creation fails with VW_ERROR_BUDGET when the
                            chunk table alone exceeds it; an edit that would need more fails
                            with VW_ERROR_BUDGET and changes nothing                          */
} vw_world_desc;

vw_status vw_world_create(const vw_world_desc *desc, vw_world **out_world, vw_error *err);
void vw_world_destroy(vw_world *world);

typedef struct vw_world_info {
    int32_t chunk_size;
    int64_t origin[3];
    int32_t size[3];         /* voxels (multiple of chunk_size)                             */
    int32_t chunks[3];       /* chunk counts per axis                                       */
    uint32_t chunk_count;    /* chunks[0]*chunks[1]*chunks[2]                                */
    uint32_t nonempty_chunks;/* chunks holding at least one solid voxel                      */
    uint64_t solid_voxels;   /* voxels with a material                                      */
    uint64_t bytes;          /* memory held                                                 */
    uint64_t max_bytes;      /* the limit on `bytes` (vw_world_desc.max_bytes)              */
} vw_world_info;

void vw_world_get_info(const vw_world *world, vw_world_info *out_info);

/* The material table (256 entries; entry 0 is unused). Defaults: index 1..255 opaque with a
 * palette colour. */
vw_status vw_world_set_material(vw_world *world, uint32_t index, const vw_material *material);
const vw_material *vw_world_material(const vw_world *world, uint32_t index);

/* Absolute voxel coordinates. vw_world_get returns 0 outside the world. vw_world_set marks
 * the chunk dirty, and the neighbour chunks whose faces it may change. */
vw_voxel vw_world_get(const vw_world *world, int64_t x, int64_t y, int64_t z);
vw_status vw_world_set(vw_world *world, int64_t x, int64_t y, int64_t z, vw_voxel value);

/* 1 when every voxel of the box [min, max) (absolute voxels) lies in the world and holds an
 * opaque material (one without VW_MAT_SEE_THROUGH); 0 otherwise, and for a box empty on an
 * axis. The mesher gives such voxels an opaque face toward every voxel that is not opaque and
 * toward the world's outside, which is what vis_query_solid_fn asks for. Costs at most one
 * read per voxel of the box (one per uniform chunk it meets), and stops at the first voxel
 * that is not opaque. Reads only: safe from several threads while nothing writes the world. */
int vw_world_box_opaque(const vw_world *world, const int64_t min[3], const int64_t max[3]);

/* Fills the box [min, max) (absolute voxels, clipped to the world) with one value. */
vw_status vw_world_fill(vw_world *world, const int64_t min[3], const int64_t max[3], vw_voxel value);

/* Chunk index of absolute chunk-relative coordinates (cx, cy, cz in [0, chunks));
 * UINT32_MAX outside that range. */
uint32_t vw_world_chunk_index(const vw_world *world, int32_t cx, int32_t cy, int32_t cz);
void vw_world_chunk_coords(const vw_world *world, uint32_t chunk_index, int32_t out_c[3]);
/* Object ID of a chunk (see the top of this file): chunk_index + 1. */
static inline uint32_t vw_chunk_object_id(uint32_t chunk_index) { return chunk_index + 1u; }
/* 1 if the chunk holds no solid voxel. */
int vw_world_chunk_empty(const vw_world *world, uint32_t chunk_index);

/* Dirty chunks: those changed (or whose neighbours changed) since the last take. Writes up
 * to `capacity` chunk indices, ascending, clears what it wrote and returns how many. Pass
 * NULL/0 to learn how many are dirty without clearing. */
size_t vw_world_take_dirty(vw_world *world, uint32_t *out_chunks, size_t capacity);
void vw_world_clear_dirty(vw_world *world);

/* ---- mesher ------------------------------------------------------------------------- */

/* An axis-aligned face rectangle, in voxels relative to the world origin: the plane
 * x[axis] = plane, covering [u0,u1] x [v0,v1] with u = (axis+1)%3, v = (axis+2)%3.
 * side is +1 if the solid voxel lies on the negative side (the face looks towards +axis),
 * -1 otherwise. flags are the material's VW_MAT_* flags. */
typedef struct vw_quad {
    uint8_t axis;
    int8_t side;
    uint8_t material;
    uint8_t flags;
    int32_t plane, u0, v0, u1, v1;
} vw_quad;

/* A growable quad array owned by the caller; reuse it across calls to avoid allocation. */
typedef struct vw_mesh {
    vw_quad *quads;
    size_t count;
    size_t capacity;
} vw_mesh;

void vw_mesh_free(vw_mesh *mesh);

/* Meshes one chunk: the faces between a solid voxel and an empty (or different
 * see-through) neighbour, looking across chunk borders (outside the world is empty), merged
 * greedily into rectangles of one axis, side and material. Replaces mesh->count. Allocates
 * only to grow `mesh`; uses about 27 KiB of stack (135 KiB for 32-voxel chunks; the threads
 * vw_mesh_chunks starts get 1 MiB). */
vw_status vw_mesh_chunk(const vw_world *world, uint32_t chunk_index, vw_mesh *mesh);

/* Meshes `count` chunks at once: meshes[i] becomes exactly what vw_mesh_chunk(world,
 * chunks[i], &meshes[i]) gives (same quads, same order), for any `threads` (0 and 1:
 * serial on the calling thread; at most 64 are used). `meshes` is caller-owned, `count`
 * entries, zeroed or reused from an earlier call (each grows as vw_mesh_chunk's does).
 * Chunk indices may repeat only if the same chunk's mesh is wanted twice. Returns VW_OK, or
 * the status of the failing chunk with the lowest i (VW_ERROR_INVALID_ARGUMENT for an index
 * out of range, VW_ERROR_OUT_OF_MEMORY); on failure every mesh may have been replaced. The
 * world must not be written during the call. Each thread uses vw_mesh_chunk's stack. */
vw_status vw_mesh_chunks(const vw_world *world, const uint32_t *chunks, size_t count, vw_mesh *meshes,
                         uint32_t threads);

/* ---- generators and loading -------------------------------------------------------- */

/* Progress: stage is a short static string ("generating", "meshing", ...), fraction 0..1. */
typedef void (*vw_progress_fn)(const char *stage, double fraction, void *user);

/* Builds a world from a SPEC: a generator "gen:NAME[:key=value]..." or a file path
 * (*.vox; *.vdb when built with OpenVDB). Generators: terrain, city, maze, each with
 * size=XxYxZ (voxels, 1..2^20 per axis, rounded up to chunks; defaults 512x128x512, maze
 * 256x16x256), seed=N (default 1), chunk=16|32, origin=X,Y,Z (rounded down to a chunk
 * multiple); "gen:default" is the default world; "gen:large" (= gen:terrain:preset=large) is
 * a 2560x160x2560 terrain with over 100,000 chunks that have a mesh. The same spec always
 * gives the same voxels, relative to the origin. A file path may end in a query:
 * "f.vox?chunk=32", "f.vdb?grid=NAME&threshold=F&transform=0|1&chunk=16|32" (see
 * vw_vdb_options). `budget` may be NULL (the defaults); a spec or file that would exceed it
 * fails with VW_ERROR_BUDGET and a message naming the number that was too big, before the
 * memory is taken, and the world keeps budget->max_bytes as its limit. A world returned
 * here has no dirty chunks. Errors in the spec:
 * VW_ERROR_INVALID_ARGUMENT with a message. `progress` may be NULL; it is called at most
 * 101 times ("generating" or "loading", fraction non-decreasing, ending at 1). */
vw_status vw_world_from_spec(const char *spec, const vw_budget *budget, vw_progress_fn progress,
                             void *progress_user, vw_world **out_world, vw_error *err);

/* vw_world_from_spec with every option: zero fields are the defaults (budget zero: the
 * default budget; threads 0 or 1: serial; progress NULL: none). */
typedef struct vw_load_options {
    vw_budget budget;
    uint32_t threads;        /* generators fill chunk columns on this many threads (files
                                load serially); the world is bit-identical for every count.
                                Each thread beyond the first needs one more generator scratch
                                (a column of C x height bytes plus the generator's own), which
                                the budget counts: threads it has no room for are not used,
                                and a parallel run that outgrows the budget is redone serially,
                                so the count never changes whether a spec loads              */
    vw_progress_fn progress; /* called on the calling thread only, as vw_world_from_spec's   */
    void *progress_user;
} vw_load_options;

/* `options` may be NULL (all defaults: same as vw_world_from_spec(spec, NULL, NULL, ...)). */
vw_status vw_world_load(const char *spec, const vw_load_options *options, vw_world **out_world, vw_error *err);

/* The spec of the built-in default world. */
const char *vw_default_spec(void);

/* Wavefront OBJ of every chunk mesh, exactly as traced: one `o ID` group per object, quads
 * as 4-vertex faces in absolute voxel coordinates. Both exporters write a regular file (or a
 * new name) through a temporary file in its directory, renamed over it once complete: on
 * failure (VW_ERROR_IO, with the path and the reason) the old file is left as it was and no
 * partial file remains. A device or FIFO is written in place and never removed. */
vw_status vw_export_obj(const vw_world *world, const char *path, vw_error *err);

/* ---- MagicaVoxel .vox (vox_read.c, vox_write.c) ------------------------------------ */

/* Parses a .vox file from memory (versions 150 and 200; scene graph, layers, materials)
 * into a new world whose origin is chosen to hold every instance. Coordinates: the .vox
 * cell [x,x+1]x[y,y+1]x[z,z+1] (z up) becomes the world cell [x,x+1]x[z,z+1]x[-y-1,-y]
 * after the scene graph is applied. On a malformed buffer: VW_ERROR_FORMAT and a message
 * with the byte offset and chunk. `chunk_size` 0 means 16. `budget` may be NULL (the
 * defaults): VW_ERROR_BUDGET when the instanced voxels or the world's memory would exceed it.
 * vw_vox_load_file reads only regular files (anything else, a FIFO or a device, is
 * VW_ERROR_IO before a byte is read), no larger than budget->max_bytes, and checks the magic
 * before it reads the rest. */
vw_status vw_vox_load_memory(const void *data, size_t size, int32_t chunk_size, const vw_budget *budget,
                             vw_world **out_world, vw_error *err);
vw_status vw_vox_load_file(const char *path, int32_t chunk_size, const vw_budget *budget, vw_world **out_world,
                           vw_error *err);

/* Writes any world as .vox (version 200), splitting it into models of at most 256 per axis
 * placed with a scene graph, so that loading it gives back the same voxels. The file is
 * written as vw_export_obj's: a failure never destroys what was at PATH. */
vw_status vw_vox_save_file(const vw_world *world, const char *path, vw_error *err);

/* ---- OpenVDB .vdb (vdb/vdb_shim.cpp; VW_WITH_OPENVDB) ------------------------------ */

typedef struct vw_vdb_options {
    const char *grid;        /* grid name; NULL = the first float grid                        */
    float fog_threshold;     /* fog volumes: solid where the active value > this (default 0)  */
    int use_transform;       /* 0: index space is voxel space (scale 1); 1: honour the grid's
                                transform (voxel size and translation, rounded to voxels)      */
    int32_t chunk_size;      /* 0 = 16                                                         */
    vw_budget budget;        /* zero fields: the defaults                                      */
} vw_vdb_options;

/* Loads one grid: level sets are solid where the value is below zero (interior, inactive
 * interior tiles included); fog volumes where the active value exceeds the threshold.
 * VW_ERROR_UNSUPPORTED when built without OpenVDB. */
vw_status vw_vdb_load_file(const char *path, const vw_vdb_options *options, vw_world **out_world, vw_error *err);

/* Describes the grids of a file, one per line ("name type class bbox active_voxels"),
 * into `out` (NUL-terminated, truncated to `capacity`). */
vw_status vw_vdb_describe_file(const char *path, char *out, size_t capacity, vw_error *err);

#ifdef __cplusplus
}
#endif

#endif /* VOXELWORLD_VW_H */
