/* accuracy_report.c — accuracy.csv, accuracy.png (gnuplot, run as an external program on a
 * generated script) and the summary table of `vis accuracy`. Files are written through
 * out_file.h (a failure never destroys the file that was there), and user strings reach
 * gnuplot only as escaped string literals (gp_string). */
#define _POSIX_C_SOURCE 200809L

#include "accuracy_report.h"

#include <errno.h>
#include <math.h>
#include <spawn.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>

#include "out_file.h"

extern char **environ;

static void set_err(char *err, size_t size, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(err, size, fmt, ap);
    va_end(ap);
}

/* "512²" for a square budget, "256×128" otherwise (UTF-8, for the table and the plot). */
static void budget_label(const acc_row *r, char *buf, size_t size)
{
    if (r->budget_w == r->budget_h)
        snprintf(buf, size, "%u\xC2\xB2", r->budget_w);
    else
        snprintf(buf, size, "%u\xC3\x97%u", r->budget_w, r->budget_h);
}

int acc_write_csv(const char *path, const acc_row *rows, size_t n, char *err, size_t err_size)
{
    vc_out_file f;
    if (vc_out_open(&f, path, err, err_size) != 0)
        return -1;
    vc_out_printf(&f, "method,width,height,time_ms,drawn,missed,missed_area,overdraw,overdraw_triangles,"
                      "occluded_culled,budget,rays,frames,truth_visible,missed_area_max,hidden,trace_ms,list_ms,"
                      "raster_ms,test_ms,missed_direct,missed_see_through,missed_reflection,missed_shadow\n");
    for (size_t i = 0; i < n; ++i) {
        const acc_row *r = &rows[i];
        int zbuf = strcmp(r->method, "zbuf") == 0;
        char a[32] = "", b[32] = "", c[32] = "", d[32] = "";
        snprintf(zbuf ? c : a, sizeof a, "%.4f", r->part_a_ms);
        snprintf(zbuf ? d : b, sizeof b, "%.4f", r->part_b_ms);
        vc_out_printf(&f, "%s,%u,%u,%.4f,%.2f,%.2f,%.6g,%.2f,%.1f,%.4f,%ux%u,%llu,%u,%.2f,%.6g,%.2f,%s,%s,%s,%s,%.2f,%.2f,%.2f,%.2f\n",
                      r->method, r->width, r->height, r->time_ms, r->s.drawn, r->s.missed, r->s.missed_area,
                      r->s.overdraw, r->s.overdraw_triangles, r->s.occluded_culled, r->budget_w, r->budget_h,
                      (unsigned long long)r->width * r->height, r->s.frames, r->s.truth_visible,
                      r->s.missed_area_max, r->s.hidden, a, b, c, d, r->s.reason_missed[0],
                      r->s.reason_missed[1], r->s.reason_missed[2], r->s.reason_missed[3]);
    }
    return vc_out_close(&f, 1, err, err_size);
}

/* ---- the plot -------------------------------------------------------------------------- */

typedef struct method_style {
    const char *method, *title, *colour;
    int point;
} method_style;

static const method_style styles[] = {
    {"ray-object", "ray pass, object IDs", "#1f5fbf", 7},
    {"ray-leaf", "ray pass, leaf IDs", "#e07000", 5},
    {"zbuf", "z-buffer culler", "#2a9d3a", 9},
};

/* Where the k-th point label of a curve goes, so that close curves and close points stay
 * readable: object IDs above their points, leaf IDs below, the culler's (whose points sit
 * close together) left, below and above in turn. */
static const char *label_place(size_t m, size_t k)
{
    if (m == 0)
        return "center offset char 0,1";
    if (m == 1)
        return "center offset char 0,-1";
    static const char *const zbuf[] = {"right offset char -0.8,0", "center offset char 0,-1.2",
                                       "center offset char 0,1.2"};
    return zbuf[k % 3];
}

/* 10^(floor(log10(smallest positive value)) - 1): where zeros are drawn on a log axis. */
static double zero_floor(const double *v, size_t n, double fallback)
{
    double m = INFINITY;
    for (size_t i = 0; i < n; ++i)
        if (v[i] > 0.0 && v[i] < m)
            m = v[i];
    if (!isfinite(m))
        return fallback;
    return pow(10.0, floor(log10(m)) - 1.0);
}

/* S as a gnuplot string literal that gnuplot reads back byte for byte and never as commands
 * (malloc'ed; NULL when out of memory). A scene named "k\nsystem \"touch X\"" once ran
 * `touch X`: a newline ends a gnuplot command even inside a string, and single quotes cannot
 * escape it. Double quotes can (\ooo octal escapes), but gnuplot runs `...` inside them and
 * reads \ as an escape, so every byte that is not a letter, a digit or a few harmless marks
 * is written as \ooo — newlines, quotes, backslashes, backquotes, ';', '@', '$', control
 * characters and UTF-8 bytes alike. For text that is shown (display != 0), control characters
 * become '?' first: a title stays one line, and cairo draws no boxes for ESC or CR. */
static char *gp_string(const char *s, int display)
{
    char *q = malloc(4 * strlen(s) + 3), *p = q;
    if (!q)
        return NULL;
    *p++ = '"';
    for (; *s; ++s) {
        unsigned char c = (unsigned char)*s;
        if (display && (c < 0x20 || c == 0x7f))
            c = '?';
        if ((c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || strchr(" .,:_-+/()", c)) {
            *p++ = (char)c;
        } else {
            *p++ = '\\';
            *p++ = (char)('0' + (c >> 6));
            *p++ = (char)('0' + ((c >> 3) & 7));
            *p++ = (char)('0' + (c & 7));
        }
    }
    *p++ = '"';
    *p = '\0';
    return q;
}

static int write_script(const char *script, const char *title, const acc_row *rows, size_t n,
                        char *err, size_t err_size)
{
    double *area = malloc((n ? n : 1) * sizeof *area), *over = malloc((n ? n : 1) * sizeof *over);
    if (!area || !over) {
        free(area);
        free(over);
        set_err(err, err_size, "out of memory");
        return -1;
    }
    for (size_t i = 0; i < n; ++i) {
        area[i] = 100.0 * rows[i].s.missed_area;
        over[i] = rows[i].s.overdraw;
    }
    double area_floor = zero_floor(area, n, 1e-4), over_floor = zero_floor(over, n, 0.1);
    char *quoted_title = gp_string(title, 1);
    vc_out_file out, *f = &out;
    if (!quoted_title || vc_out_open(f, script, err, err_size) != 0) {
        if (!quoted_title)
            set_err(err, err_size, "out of memory");
        free(quoted_title);
        free(area);
        free(over);
        return -1;
    }
    vc_out_printf(f, "# Written by `vis accuracy`; `gnuplot accuracy.gp` in this directory redraws accuracy.png.\n");
    /* `vis accuracy` names a temporary output on gnuplot's command line (acc_plot). */
    vc_out_printf(f, "set encoding utf8\nset terminal pngcairo size 1400,600 font 'sans,11' noenhanced\n"
                     "set output exists(\"vis_output\") ? vis_output : 'accuracy.png'\n");
    /* One datablock per method: time, missed area (%), overdraw (objects), label; zeros are
     * moved to the axis floor, which is labelled 0. */
    for (size_t m = 0; m < sizeof styles / sizeof styles[0]; ++m) {
        vc_out_printf(f, "$m%zu << EOD\n", m);
        for (size_t i = 0; i < n; ++i) {
            if (strcmp(rows[i].method, styles[m].method) != 0)
                continue;
            char label[32];
            budget_label(&rows[i], label, sizeof label);
            vc_out_printf(f, "%.6g %.6g %.6g \"%s\"\n", rows[i].time_ms, area[i] > 0.0 ? area[i] : area_floor,
                          over[i] > 0.0 ? over[i] : over_floor, label);
        }
        vc_out_printf(f, "EOD\n");
    }
    vc_out_printf(f, "set multiplot layout 1,2 title %s font ',13'\n", quoted_title);
    vc_out_printf(f, "set logscale xy\nset grid xtics ytics mxtics mytics lc rgb '#dddddd'\n"
                     "set key top right box opaque\nset xlabel 'time per frame, ms (median over the path; log)'\n"
                     "set format y '%%g'\n"
                     "set offsets graph 0.08, graph 0.12, graph 0.1, graph 0.05\n");
    for (int panel = 0; panel < 2; ++panel) {
        double floor_v = panel == 0 ? area_floor : over_floor;
        const double *val = panel == 0 ? area : over;
        int col = panel == 0 ? 2 : 3;
        vc_out_printf(f, "set ylabel '%s'\n",
                      panel == 0 ? "missed area: % of the display that pops in (mean per frame; log)"
                                 : "overdraw: objects drawn but not visible (mean per frame; log)");
        vc_out_printf(f, "set title '%s'\n",
                      panel == 0 ? "cost vs popping (lower left is better)"
                                 : "cost vs overdraw (lower left is better)");
        vc_out_printf(f, "set yrange [%.6g:*]\nset ytics autofreq\nset ytics add ('0' %.6g)\nunset label\n",
                      floor_v * 0.5, floor_v);
        for (size_t m = 0; m < sizeof styles / sizeof styles[0]; ++m) {
            size_t k = 0;
            for (size_t i = 0; i < n; ++i) {
                if (strcmp(rows[i].method, styles[m].method) != 0)
                    continue;
                char label[32];
                budget_label(&rows[i], label, sizeof label);
                vc_out_printf(f, "set label \"%s\" at first %.6g, first %.6g %s font ',9' tc rgb '%s' front\n", label,
                              rows[i].time_ms, val[i] > 0.0 ? val[i] : floor_v, label_place(m, k++), styles[m].colour);
            }
        }
        vc_out_printf(f, "plot ");
        int first = 1;
        for (size_t m = 0; m < sizeof styles / sizeof styles[0]; ++m) {
            int present = 0;
            for (size_t i = 0; i < n; ++i)
                present |= strcmp(rows[i].method, styles[m].method) == 0;
            if (!present)
                continue;
            vc_out_printf(f, "%s$m%zu using 1:%d with linespoints lw 2 pt %d ps 1.3 lc rgb '%s' title '%s'",
                          first ? "" : ", \\\n     ", m, col, styles[m].point, styles[m].colour, styles[m].title);
            first = 0;
        }
        if (first)
            vc_out_printf(f, "NaN notitle");
        vc_out_printf(f, "\n");
    }
    vc_out_printf(f, "unset multiplot\n");
    free(quoted_title);
    free(area);
    free(over);
    return vc_out_close(f, 1, err, err_size);
}

int acc_plot(const char *dir, const char *title, const acc_row *rows, size_t n, char *err, size_t err_size)
{
    char script[4096], png[4096];
    snprintf(script, sizeof script, "%s/accuracy.gp", dir);
    snprintf(png, sizeof png, "%s/accuracy.png", dir);
    if (write_script(script, title, rows, n, err, err_size) != 0)
        return -1;
    const char *prog = getenv("VIS_GNUPLOT");
    if (!prog || !prog[0])
        prog = "gnuplot";
    /* gnuplot draws into the out_file temporary, renamed over accuracy.png only when the
     * picture is complete: a failed run leaves the old picture, and no partial one. */
    vc_out_file out;
    if (vc_out_open(&out, png, err, err_size) != 0)
        return -1;
    fclose(out.f);
    out.f = NULL;
    /* Its name reaches gnuplot as an escaped literal; the script's path as a file argument,
     * which gnuplot opens and never parses. */
    char *name = gp_string(vc_out_name(&out), 0), *set = name ? malloc(strlen(name) + 16) : NULL;
    if (!set) {
        free(name);
        vc_out_close(&out, 0, err, err_size);
        set_err(err, err_size, "out of memory");
        return -1;
    }
    sprintf(set, "vis_output = %s", name);
    free(name);
    /* gnuplot's own messages go to stderr: stdout carries only the result (--json). */
    posix_spawn_file_actions_t fa;
    if (posix_spawn_file_actions_init(&fa) != 0) {
        free(set);
        vc_out_close(&out, 0, err, err_size);
        set_err(err, err_size, "cannot start %s", prog);
        return -1;
    }
    posix_spawn_file_actions_adddup2(&fa, 2, 1);
    char *argv[] = {(char *)prog, "-e", set, script, NULL};
    pid_t pid;
    int rc = posix_spawnp(&pid, prog, &fa, NULL, argv, environ);
    posix_spawn_file_actions_destroy(&fa);
    free(set);
    if (rc != 0) {
        vc_out_close(&out, 0, err, err_size);
        set_err(err, err_size, "%s not found (%s): install gnuplot-nox for accuracy.png; the CSV and %s are written",
                prog, strerror(rc), script);
        return 1;
    }
    int status = 0;
    while (waitpid(pid, &status, 0) < 0) {
        if (errno != EINTR) {
            set_err(err, err_size, "waiting for %s: %s", prog, strerror(errno));
            vc_out_close(&out, 0, err, err_size);
            return -1;
        }
    }
    if (WIFEXITED(status) && WEXITSTATUS(status) == 127) {
        vc_out_close(&out, 0, err, err_size);
        set_err(err, err_size, "%s could not be run: install gnuplot-nox for accuracy.png", prog);
        return 1;
    }
    /* An empty regular file means gnuplot wrote nothing; a device has no size to check. */
    struct stat st;
    int drawn = WIFEXITED(status) && WEXITSTATUS(status) == 0 && stat(vc_out_name(&out), &st) == 0 &&
                (!S_ISREG(st.st_mode) || st.st_size > 0);
    if (!drawn) {
        vc_out_close(&out, 0, err, err_size);
        set_err(err, err_size, "%s %s failed (exit %d): no %s", prog, script,
                WIFEXITED(status) ? WEXITSTATUS(status) : -1, png);
        return -1;
    }
    return vc_out_close(&out, 1, err, err_size);
}

/* ---- the table ------------------------------------------------------------------------- */

void acc_print_table(FILE *f, const acc_row *rows, size_t n, uint32_t dw, uint32_t dh)
{
    fprintf(f, "%-10s %7s %9s %9s %8s %8s %8s %10s %9s %8s %10s %9s\n", "method", "budget", "buffer", "ms/frame",
            "drawn", "missed", "missed %", "missed px", "worst %", "overdraw", "ovd tris", "occl cull");
    for (size_t i = 0; i < n; ++i) {
        const acc_row *r = &rows[i];
        char label[32], buf[32];
        budget_label(r, label, sizeof label);
        snprintf(buf, sizeof buf, "%ux%u", r->width, r->height);
        /* %*s counts bytes, and the label's ² or × takes two bytes for one column. */
        int extra = 1;
        fprintf(f, "%-10s %*s %9s %9.2f %8.1f %8.2f %8.4f %10.0f %9.4f %8.1f %10.0f %8.1f%%\n", r->method,
                7 + extra, label, buf, r->time_ms, r->s.drawn, r->s.missed, 100.0 * r->s.missed_area,
                r->s.missed_area * (double)dw * (double)dh, 100.0 * r->s.missed_area_max, r->s.overdraw,
                r->s.overdraw_triangles, 100.0 * r->s.occluded_culled);
    }
}

void acc_print_reasons(FILE *f, const acc_row *rows, size_t n)
{
    static const char *const names[VIS_REASON_COUNT] = {"direct", "see-through", "reflection", "shadow"};
    fprintf(f, "%-10s %7s %9s", "method", "budget", "buffer");
    for (int k = 0; k < VIS_REASON_COUNT; ++k)
        fprintf(f, " %18s", names[k]);
    fprintf(f, "\n");
    for (size_t i = 0; i < n; ++i) {
        const acc_row *r = &rows[i];
        char label[32], buf[32];
        budget_label(r, label, sizeof label);
        snprintf(buf, sizeof buf, "%ux%u", r->width, r->height);
        fprintf(f, "%-10s %8s %9s", r->method, label, buf); /* 8: the label's two-byte mark */
        for (int k = 0; k < VIS_REASON_COUNT; ++k) {
            char cell[40];
            snprintf(cell, sizeof cell, "%.1f of %.1f", r->s.reason_missed[k], r->s.reason_truth[k]);
            fprintf(f, " %18s", cell);
        }
        fprintf(f, "\n");
    }
}
