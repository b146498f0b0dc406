/* accuracy_report.h — what `vis accuracy` writes: accuracy.csv, the gnuplot picture
 * accuracy.png (through a generated accuracy.gp), and the summary table on stdout. */
#ifndef VIS_CLI_ACCURACY_REPORT_H
#define VIS_CLI_ACCURACY_REPORT_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include "accuracy.h"

/* One method at one resolution, over the frames of the path. */
typedef struct acc_row {
    const char *method;          /* "ray-object", "ray-leaf", "zbuf"                          */
    uint32_t budget_w, budget_h; /* the budget asked for: 512 x 512                          */
    uint32_t width, height;      /* the buffer traced: that many pixels, the display's aspect */
    double time_ms;              /* median over the frames of each frame's median pass        */
    double part_a_ms, part_b_ms; /* the same for the parts: trace and draw list (ray), raster
                                    and box tests (zbuf)                                      */
    vc_accuracy_summary s;       /* means over the frames                                     */
} acc_row;

/* Writes the CSV. Returns 0, or -1 with the reason in err. */
int acc_write_csv(const char *path, const acc_row *rows, size_t n, char *err, size_t err_size);

/* Writes DIR/accuracy.gp and runs gnuplot on it to make DIR/accuracy.png ($VIS_GNUPLOT names
 * the program, default "gnuplot"; its output goes to stderr). Returns 0 when the PNG was
 * written, 1 when gnuplot could not be started (the script is still there), -1 on another
 * failure; err says why. */
int acc_plot(const char *dir, const char *title, const acc_row *rows, size_t n, char *err, size_t err_size);

/* The summary table, one line per row. */
void acc_print_table(FILE *f, const acc_row *rows, size_t n, uint32_t display_w, uint32_t display_h);

/* With --effects: per row, the truth objects of each reason that the row misses, "M of T"
 * (means per view; an object with several reasons counts under each). */
void acc_print_reasons(FILE *f, const acc_row *rows, size_t n);

#endif
