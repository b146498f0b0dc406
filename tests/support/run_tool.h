/* run_tool.h — running a built binary from a test (stdout and stderr captured to files) and
 * checking what it left on disk. Shared by test_cli, test_accuracy and test_vox. */
#ifndef VIS_TEST_RUN_TOOL_H
#define VIS_TEST_RUN_TOOL_H

#include <stddef.h>

typedef struct vt_run_result {
    int code;        /* exit code, or -1 if it did not exit normally */
    char *out;       /* stdout (NUL-terminated, malloc'ed)          */
    char *err;       /* stderr                                      */
    char args[2048]; /* the arguments, for messages                 */
} vt_run_result;

/* Checks the exit code, showing the command and its stderr when it is not the expected one. */
#define vt_assert_exit(r, expected)                                                               \
    do {                                                                                          \
        if ((r).code != (expected))                                                               \
            print_message("%s -> exit %d (expected %d)\n  stderr: %s\n", (r).args, (r).code,      \
                          (expected), (r).err);                                                   \
        assert_int_equal((r).code, (expected));                                                   \
    } while (0)

/* The whole file as a NUL-terminated string (empty when it cannot be read); caller frees. */
char *vt_slurp(const char *path);

/* Runs `ENV 'EXE' ARGS` through the shell (ARGS is shell text made from FMT; ENV may be NULL,
 * else shell assignments such as "VIS_GNUPLOT=false"), stdout and stderr going to
 * TMP_DIR/stdout.txt and TMP_DIR/stderr.txt. */
vt_run_result vt_run(const char *exe, const char *tmp_dir, const char *env, const char *fmt, ...)
    __attribute__((format(printf, 4, 5)));

/* Runs EXE in CWD with ARGS (NULL-terminated, at most 30) passed as they are, no shell in
 * between, so that names with newlines and quotes reach it byte for byte; output as vt_run. */
vt_run_result vt_run_argv(const char *exe, const char *tmp_dir, const char *cwd, const char *const *args);

void vt_run_free(vt_run_result *r);

/* A fresh directory /tmp/NAME_XXXXXX in DIR (SIZE bytes); 0, or -1 when it cannot be made. */
int vt_tmp_dir_make(char *dir, size_t size, const char *name);
/* Removes DIR and everything in it; 0, or -1 on failure. */
int vt_tmp_dir_remove(const char *dir);
/* For a cmocka group setup of tests that run EXE: makes DIR as vt_tmp_dir_make and hands it
 * to vt_tmp_dir_teardown through *STATE. -1 when it cannot, or when EXE is not built. */
int vt_run_setup(void **state, char *dir, size_t size, const char *name, const char *exe);
/* A cmocka group teardown: removes the directory *STATE names (set by vt_run_setup). */
int vt_tmp_dir_teardown(void **state);

/* DIR holds exactly NAMES (NULL-terminated): nothing injected ran, no temporary file is left. */
void vt_assert_dir_holds(const char *dir, const char *const *names);

/* A private copy of /dev/full (character device 1,7: every write fails with ENOSPC), so that
 * a regression deletes this node and not the system's. 0 when mknod is not allowed. */
int vt_make_full_device(const char *path);
/* 1 when PATH is such a node (a failed write left it in place). */
int vt_is_full_device(const char *path);

#endif
