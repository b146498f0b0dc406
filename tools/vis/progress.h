/* progress.h — the progress bar the CLI draws on stderr while a world is generated and meshed
 * (the libraries only report fractions through vw_progress_fn). */
#ifndef VIS_CLI_PROGRESS_H
#define VIS_CLI_PROGRESS_H

typedef enum cli_progress_mode {
    CLI_PROGRESS_OFF = 0,  /* draw nothing                                                  */
    CLI_PROGRESS_AUTO,     /* a bar when stderr is a terminal, nothing otherwise            */
    CLI_PROGRESS_ALWAYS    /* a bar on a terminal, one line per finished stage otherwise    */
} cli_progress_mode;

typedef struct cli_progress {
    int bar;               /* redraw a bar in place (stderr is a terminal)                  */
    int lines;             /* print "stage ... done" lines                                  */
    char stage[32];        /* current stage, "" when none                                   */
    int drawn;             /* last drawn permille, -1 when nothing drawn for this stage      */
    double stage_start_ms;
} cli_progress;

void cli_progress_init(cli_progress *p, cli_progress_mode mode);

/* A vw_progress_fn; `user` is the cli_progress. */
void cli_progress_update(const char *stage, double fraction, void *user);

/* Ends the current stage's line (call once the work is done). */
void cli_progress_finish(cli_progress *p);

#endif
