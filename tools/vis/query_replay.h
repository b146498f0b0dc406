/* query_replay.h — `vis query` replays: JSON Lines, one tick a line (docs/server.md,
 * "Replay format"), read with Jansson and validated value by value before use. */
#ifndef VIS_CLI_QUERY_REPLAY_H
#define VIS_CLI_QUERY_REPLAY_H

#include <stdint.h>
#include <stdio.h>

#include "vis/vis.h"

/* Budgets on what one line may hold; a line over them is rejected, never truncated. */
#define QR_MAX_LINE_BYTES (4u << 20)
#define QR_MAX_EDITS 4096u

typedef struct qr_edit {
    int64_t x, y, z;
    uint32_t value; /* 0 = air, 1..255 a material */
} qr_edit;

/* One tick; the arrays are the reader's, sized at qr_open and reused for every line. */
typedef struct qr_tick {
    uint64_t tick;
    vis_query_viewer *viewers;
    uint32_t viewer_count;
    vis_query_entity *entities;
    uint32_t entity_count;
    qr_edit *edits;
    uint32_t edit_count;
} qr_tick;

typedef struct qr_header {
    char scene[256];   /* the SPEC the replay was made on ("" if not given)           */
    double tick_ms;    /* 0 if not given                                              */
} qr_header;

typedef struct qr_reader qr_reader;

/* Opens a replay; max_viewers / max_entities bound every line. The world box (world
 * coordinates) bounds edit coordinates. Returns NULL with a message in err. */
qr_reader *qr_open(const char *path, uint32_t max_viewers, uint32_t max_entities, const int64_t world_min[3],
                   const int64_t world_max[3], char *err, size_t err_size);
void qr_close(qr_reader *r);
/* The header line's fields (the first line, when it has "replay"). */
const qr_header *qr_get_header(const qr_reader *r);
/* Next tick: 1 read, 0 end of file, -1 a malformed line (message in err, with the line
 * number and the field). */
int qr_next(qr_reader *r, qr_tick *out, char *err, size_t err_size);

#endif
