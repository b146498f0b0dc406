/* id_png.h — the ID buffer as a picture: a distinct colour per ID, black where nothing is hit. */
#ifndef VIS_CLI_ID_PNG_H
#define VIS_CLI_ID_PNG_H

#include <stddef.h>
#include <stdint.h>

/* 1 when this build can write PNG files (libpng was found). */
int cli_png_available(void);

/* The colour of an ID as 0xRRGGBB: a hash, never black for ID != 0; 0 for ID 0. */
uint32_t cli_id_colour(uint32_t id);

/* Writes a width x height RGB PNG of the IDs (row-major, top row first). Returns 0, or -1
 * with a message in err. */
int cli_png_write_ids(const char *path, const uint32_t *ids, uint32_t width, uint32_t height, char *err,
                      size_t err_size);

#endif
