/* upload.cl — what an edit sends, copied into place on the device (cl_scene.c).
 *
 * A partial scene sync packs every changed range (a leaf's header, bucket table, quads and
 * triangles; an object's slot; the rewritten part of the object leaf lists; cell map
 * entries) into one staging buffer: a header of STAGE_RANGES (cl_scene.c) entries of (array,
 * first word, words, source word) as ulongs, then the words. One write and this one kernel
 * replace a write per range, each of which costs the driver a few microseconds whatever its
 * size. Every scene array is a whole number of 32-bit words (cl_scene.c checks the element
 * sizes), so the copy is by word. */

/* The arrays a range may target, in this order (cl_scene.c, stage_array). */
#define VIS_CL_STAGE_LEAVES 0u
#define VIS_CL_STAGE_BUCKETS 1u
#define VIS_CL_STAGE_QUADS 2u
#define VIS_CL_STAGE_TRIS 3u
#define VIS_CL_STAGE_OBJECTS 4u
#define VIS_CL_STAGE_OBJECT_LEAVES 5u
#define VIS_CL_STAGE_ROPE_INDEX 6u

/* One work-group per range. */
__kernel void vis_scatter_words(const __global ulong4 *restrict ranges, const __global uint *restrict stage,
                                __global uint *leaves, __global uint *buckets, __global uint *quads,
                                __global uint *tris, __global uint *objects, __global uint *object_leaves,
                                __global uint *rope_index)
{
    const ulong4 r = ranges[get_group_id(0)]; /* (array, first word, words, source word) */
    __global uint *dst = r.x == VIS_CL_STAGE_LEAVES          ? leaves
                         : r.x == VIS_CL_STAGE_BUCKETS       ? buckets
                         : r.x == VIS_CL_STAGE_QUADS         ? quads
                         : r.x == VIS_CL_STAGE_TRIS          ? tris
                         : r.x == VIS_CL_STAGE_OBJECTS       ? objects
                         : r.x == VIS_CL_STAGE_OBJECT_LEAVES ? object_leaves
                                                             : rope_index;
    for (ulong w = get_local_id(0); w < r.z; w += get_local_size(0))
        dst[r.y + w] = stage[r.w + w];
}
