/* accuracy_report.c — accuracy.csv, accuracy.png (gnuplot, run as an external program on a
 * generated script) and the summary table of `vis accuracy`. */
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
    FILE *f = fopen(path, "w");
    if (!f) {
        set_err(err, err_size, "cannot open %s for writing: %s", path, strerror(errno));
        return -1;
    }
    fprintf(f, "method,width,height,time_ms,drawn,missed,missed_area,overdraw,overdraw_triangles,occluded_culled,"
               "budget,rays,frames,truth_visible,missed_area_max,hidden,trace_ms,list_ms,raster_ms,test_ms\n");
    for (size_t i = 0; i < n; ++i) {
        const acc_row *r = &rows[i];
        int zbuf = strcmp(r->method, "zbuf") == 0;
        char a[32] = "", b[32] = "", c[32] = "", d[32] = "";
        snprintf(zbuf ? c : a, sizeof a, "%.4f", r->part_a_ms);
        snprintf(zbuf ? d : b, sizeof b, "%.4f", r->part_b_ms);
        fprintf(f, "%s,%u,%u,%.4f,%.2f,%.2f,%.6g,%.2f,%.1f,%.4f,%ux%u,%llu,%u,%.2f,%.6g,%.2f,%s,%s,%s,%s\n",
                r->method, r->width, r->height, r->time_ms, r->s.drawn, r->s.missed, r->s.missed_area,
                r->s.overdraw, r->s.overdraw_triangles, r->s.occluded_culled, r->budget_w, r->budget_h,
                (unsigned long long)r->width * r->height, r->s.frames, r->s.truth_visible, r->s.missed_area_max,
                r->s.hidden, a, b, c, d);
    }
    int bad = ferror(f) != 0;
    if (fclose(f) != 0)
        bad = 1;
    if (bad) {
        set_err(err, err_size, "writing %s failed: %s", path, strerror(errno));
        return -1;
    }
    return 0;
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

static void gp_quote(FILE *f, const char *s)
{
    fputc('\'', f);
    for (; *s; ++s) {
        if (*s == '\'')
            fputc('\'', f); /* '' is a quote inside a single-quoted gnuplot string */
        fputc(*s, f);
    }
    fputc('\'', f);
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
    FILE *f = fopen(script, "w");
    if (!f) {
        free(area);
        free(over);
        set_err(err, err_size, "cannot open %s for writing: %s", script, strerror(errno));
        return -1;
    }
    fprintf(f, "# Written by `vis accuracy`; `gnuplot accuracy.gp` in this directory redraws accuracy.png.\n");
    fprintf(f, "set encoding utf8\nset terminal pngcairo size 1400,600 font 'sans,11' noenhanced\n"
               "set output 'accuracy.png'\n");
    /* One datablock per method: time, missed area (%), overdraw (objects), label; zeros are
     * moved to the axis floor, which is labelled 0. */
    for (size_t m = 0; m < sizeof styles / sizeof styles[0]; ++m) {
        fprintf(f, "$m%zu << EOD\n", m);
        for (size_t i = 0; i < n; ++i) {
            if (strcmp(rows[i].method, styles[m].method) != 0)
                continue;
            char label[32];
            budget_label(&rows[i], label, sizeof label);
            fprintf(f, "%.6g %.6g %.6g \"%s\"\n", rows[i].time_ms, area[i] > 0.0 ? area[i] : area_floor,
                    over[i] > 0.0 ? over[i] : over_floor, label);
        }
        fprintf(f, "EOD\n");
    }
    fprintf(f, "set multiplot layout 1,2 title ");
    gp_quote(f, title);
    fprintf(f, " font ',13'\n");
    fprintf(f, "set logscale xy\nset grid xtics ytics mxtics mytics lc rgb '#dddddd'\nset key top right box opaque\n"
               "set xlabel 'time per frame, ms (median over the path; log)'\nset format y '%%g'\n"
               "set offsets graph 0.08, graph 0.12, graph 0.1, graph 0.05\n");
    for (int panel = 0; panel < 2; ++panel) {
        double floor_v = panel == 0 ? area_floor : over_floor;
        const double *val = panel == 0 ? area : over;
        int col = panel == 0 ? 2 : 3;
        fprintf(f, "set ylabel '%s'\n",
                panel == 0 ? "missed area: % of the display that pops in (mean per frame; log)"
                           : "overdraw: objects drawn but not visible (mean per frame; log)");
        fprintf(f, "set title '%s'\n",
                panel == 0 ? "cost vs popping (lower left is better)" : "cost vs overdraw (lower left is better)");
        fprintf(f, "set yrange [%.6g:*]\nset ytics autofreq\nset ytics add ('0' %.6g)\nunset label\n",
                floor_v * 0.5, floor_v);
        for (size_t m = 0; m < sizeof styles / sizeof styles[0]; ++m) {
            size_t k = 0;
            for (size_t i = 0; i < n; ++i) {
                if (strcmp(rows[i].method, styles[m].method) != 0)
                    continue;
                char label[32];
                budget_label(&rows[i], label, sizeof label);
                fprintf(f, "set label \"%s\" at first %.6g, first %.6g %s font ',9' tc rgb '%s' front\n", label,
                        rows[i].time_ms, val[i] > 0.0 ? val[i] : floor_v, label_place(m, k++), styles[m].colour);
            }
        }
        fprintf(f, "plot ");
        int first = 1;
        for (size_t m = 0; m < sizeof styles / sizeof styles[0]; ++m) {
            int present = 0;
            for (size_t i = 0; i < n; ++i)
                present |= strcmp(rows[i].method, styles[m].method) == 0;
            if (!present)
                continue;
            fprintf(f, "%s$m%zu using 1:%d with linespoints lw 2 pt %d ps 1.3 lc rgb '%s' title '%s'",
                    first ? "" : ", \\\n     ", m, col, styles[m].point, styles[m].colour, styles[m].title);
            first = 0;
        }
        if (first)
            fprintf(f, "NaN notitle");
        fprintf(f, "\n");
    }
    fprintf(f, "unset multiplot\n");
    free(area);
    free(over);
    int bad = ferror(f) != 0;
    if (fclose(f) != 0)
        bad = 1;
    if (bad) {
        set_err(err, err_size, "writing %s failed: %s", script, strerror(errno));
        return -1;
    }
    return 0;
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
    remove(png);
    /* gnuplot's own messages go to stderr: stdout carries only the result (--json). */
    posix_spawn_file_actions_t fa;
    if (posix_spawn_file_actions_init(&fa) != 0) {
        set_err(err, err_size, "cannot start %s", prog);
        return -1;
    }
    posix_spawn_file_actions_adddup2(&fa, 2, 1);
    /* Run in DIR (gnuplot's `cd`), so that the script's relative output name works there. */
    char cd[4200];
    size_t k = 0;
    k += (size_t)snprintf(cd, sizeof cd, "cd '");
    for (const char *p = dir; *p && k + 4 < sizeof cd; ++p) {
        if (*p == '\'')
            cd[k++] = '\'';
        cd[k++] = *p;
    }
    cd[k++] = '\'';
    cd[k] = '\0';
    char *argv[] = {(char *)prog, "-e", cd, "accuracy.gp", NULL};
    pid_t pid;
    int rc = posix_spawnp(&pid, prog, &fa, NULL, argv, environ);
    posix_spawn_file_actions_destroy(&fa);
    if (rc != 0) {
        set_err(err, err_size, "%s not found (%s): install gnuplot-nox for accuracy.png; the CSV and %s are written",
                prog, strerror(rc), script);
        return 1;
    }
    int status = 0;
    while (waitpid(pid, &status, 0) < 0) {
        if (errno != EINTR) {
            set_err(err, err_size, "waiting for %s: %s", prog, strerror(errno));
            return -1;
        }
    }
    if (WIFEXITED(status) && WEXITSTATUS(status) == 127) {
        set_err(err, err_size, "%s could not be run: install gnuplot-nox for accuracy.png", prog);
        return 1;
    }
    struct stat st;
    if (!WIFEXITED(status) || WEXITSTATUS(status) != 0 || stat(png, &st) != 0 || st.st_size == 0) {
        set_err(err, err_size, "%s %s failed (exit %d): no %s", prog, script,
                WIFEXITED(status) ? WEXITSTATUS(status) : -1, png);
        return -1;
    }
    return 0;
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
