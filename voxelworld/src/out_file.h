/* out_file.h — the file an exporter writes (vw_vox_save_file, vw_export_obj), never destroyed
 * on failure: internal/vwi_file.h (the rule and the code, shared with the tools), with its
 * failures as vw_status and vw_error. */
#ifndef VOXELWORLD_OUT_FILE_H
#define VOXELWORLD_OUT_FILE_H

#include "voxelworld/vw.h"
#include "vwi_file.h"

/* Opens PATH for binary writing: VW_OK, or VW_ERROR_IO with the reason in err. */
vw_status vwi_out_open(vwi_file *o, const char *path, vw_error *err);

/* Finishes with the caller's status (vwi_file_finish). Returns VW_OK; VW_ERROR_IO with the
 * path and the reason in err when the failure was a write, flush, close or rename; else the
 * caller's status, err untouched. */
vw_status vwi_out_close(vwi_file *o, vw_status status, vw_error *err);

#endif
