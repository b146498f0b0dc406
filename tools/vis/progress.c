/* progress.c — a one-line progress bar on stderr. */
#define _POSIX_C_SOURCE 200809L

#include "progress.h"

#include <stdio.h>
#include <string.h>
#include <unistd.h>

#include "timer.h"

#define BAR_WIDTH 40

void cli_progress_init(cli_progress *p, cli_progress_mode mode)
{
    memset(p, 0, sizeof *p);
    int tty = isatty(STDERR_FILENO);
    p->bar = mode != CLI_PROGRESS_OFF && tty;
    p->lines = mode == CLI_PROGRESS_ALWAYS && !tty;
    p->drawn = -1;
}

static void end_stage(cli_progress *p)
{
    if (!p->stage[0])
        return;
    double s = (vc_now_ms() - p->stage_start_ms) / 1e3;
    if (p->bar)
        fprintf(stderr, "\r  %-12s [%.*s] 100%%  %.2f s\n", p->stage, BAR_WIDTH,
                "########################################", s);
    else if (p->lines)
        fprintf(stderr, "  %-12s done  %.2f s\n", p->stage, s);
    fflush(stderr);
    p->stage[0] = '\0';
}

void cli_progress_update(const char *stage, double fraction, void *user)
{
    cli_progress *p = user;
    if (!p || (!p->bar && !p->lines))
        return;
    if (strncmp(p->stage, stage, sizeof p->stage - 1) != 0) {
        end_stage(p);
        snprintf(p->stage, sizeof p->stage, "%s", stage);
        p->stage_start_ms = vc_now_ms();
        p->drawn = -1;
    }
    if (!p->bar)
        return;
    if (fraction < 0.0)
        fraction = 0.0;
    if (fraction > 1.0)
        fraction = 1.0;
    int permille = (int)(fraction * 1000.0);
    if (permille == p->drawn)
        return;
    p->drawn = permille;
    int filled = (int)(fraction * BAR_WIDTH);
    fprintf(stderr, "\r  %-12s [%.*s%*s] %3d%%", p->stage, filled, "########################################",
            BAR_WIDTH - filled, "", permille / 10);
    fflush(stderr);
}

void cli_progress_finish(cli_progress *p)
{
    end_stage(p);
}
