/* export_obj.c — the chunk meshes as a Wavefront OBJ file, exactly as traced.
 *
 * One `o ID` group per chunk with a non-empty mesh (ID = vw_chunk_object_id), four vertices
 * and one quad face per vw_quad, in absolute integer voxel coordinates (origin + local, both
 * exact in int64, printed as integers). Faces wind counter-clockwise seen from the side they
 * face, the OBJ/OpenGL convention, so (v1 - v0) x (v2 - v0) points along the face's side. */
#include <stdio.h>

#include "out_file.h"
#include "vw_internal.h"

static void corner(const vw_world *w, const vw_quad *q, int32_t u, int32_t v, long long out[3])
{
    const int a = q->axis, ua = (a + 1) % 3, va = (a + 2) % 3;
    out[a] = (long long)(w->origin[a] + q->plane);
    out[ua] = (long long)(w->origin[ua] + u);
    out[va] = (long long)(w->origin[va] + v);
}

vw_status vw_export_obj(const vw_world *w, const char *path, vw_error *err)
{
    if (!w || !path)
        return vwi_fail(err, VW_ERROR_INVALID_ARGUMENT, "vw_export_obj: world and path must not be NULL");
    /* Through out_file.h: a failed export leaves what was at PATH as it was, and no partial
     * file. */
    vwi_file f;
    vw_status st = vwi_out_open(&f, path, err);
    if (st != VW_OK)
        return st;
    vw_mesh mesh = {NULL, 0, 0};
    unsigned long long next_vertex = 1; /* OBJ indices are 1-based and file-global */
    vwi_file_printf(&f, "# voxelworld chunk meshes: one object per chunk, quads in absolute voxel coordinates\n");
    for (uint32_t i = 0; i < w->chunk_count && st == VW_OK && !f.error; i++) {
        if (w->chunk[i].solid == 0)
            continue;
        st = vw_mesh_chunk(w, i, &mesh);
        if (st != VW_OK || mesh.count == 0)
            continue;
        vwi_file_printf(&f, "o %u\n", (unsigned)vw_chunk_object_id(i));
        for (size_t k = 0; k < mesh.count; k++) {
            const vw_quad *q = &mesh.quads[k];
            /* (u0,v0) (u1,v0) (u1,v1) (u0,v1) turns from u towards v; u x v = +axis, so this
             * order faces +axis, and the reverse faces -axis. */
            const int32_t uv[4][2] = {{q->u0, q->v0}, {q->u1, q->v0}, {q->u1, q->v1}, {q->u0, q->v1}};
            for (int c = 0; c < 4; c++) {
                long long p[3];
                const int j = q->side > 0 ? c : 3 - c;
                corner(w, q, uv[j][0], uv[j][1], p);
                vwi_file_printf(&f, "v %lld %lld %lld\n", p[0], p[1], p[2]);
            }
            vwi_file_printf(&f, "f %llu %llu %llu %llu\n", next_vertex, next_vertex + 1, next_vertex + 2,
                           next_vertex + 3);
            next_vertex += 4;
        }
    }
    vw_mesh_free(&mesh);
    if (st != VW_OK)
        vwi_fail(err, st, "%s: meshing failed: %s", path, vw_status_string(st));
    return vwi_out_close(&f, st, err);
}
