/* run_tool.c — see run_tool.h. */
#define _POSIX_C_SOURCE 200809L
#define _XOPEN_SOURCE 700 /* mknod and S_IFCHR */

#include "run_tool.h"

#include <dirent.h>
#include <fcntl.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmocka.h>

#include "test_support.h"

char *vt_slurp(const char *path)
{
    size_t n = 0;
    char *data = vt_read_file(path, &n);
    char *s = malloc(n + 1);
    assert_non_null(s);
    if (data)
        memcpy(s, data, n);
    s[n] = '\0';
    free(data);
    return s;
}

static vt_run_result collect(const char *exe, const char *tmp_dir, int status, const char *args)
{
    char path[512];
    const char *name = strrchr(exe, '/');
    vt_run_result r;
    r.code = status != -1 && WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    snprintf(path, sizeof path, "%s/stdout.txt", tmp_dir);
    r.out = vt_slurp(path);
    snprintf(path, sizeof path, "%s/stderr.txt", tmp_dir);
    r.err = vt_slurp(path);
    snprintf(r.args, sizeof r.args, "%s %s", name ? name + 1 : exe, args);
    return r;
}

vt_run_result vt_run(const char *exe, const char *tmp_dir, const char *env, const char *fmt, ...)
{
    char args[2048], cmd[4096];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(args, sizeof args, fmt, ap);
    va_end(ap);
    snprintf(cmd, sizeof cmd, "%s '%s' %s >'%s/stdout.txt' 2>'%s/stderr.txt'", env ? env : "", exe, args, tmp_dir,
             tmp_dir);
    return collect(exe, tmp_dir, system(cmd), args);
}

vt_run_result vt_run_argv(const char *exe, const char *tmp_dir, const char *cwd, const char *const *args)
{
    char out_path[512], err_path[512], shown[2048] = "";
    snprintf(out_path, sizeof out_path, "%s/stdout.txt", tmp_dir);
    snprintf(err_path, sizeof err_path, "%s/stderr.txt", tmp_dir);
    const char *argv[32] = {exe};
    size_t n = 1;
    for (; args[n - 1]; ++n) {
        assert_true(n + 1 < sizeof argv / sizeof argv[0]);
        argv[n] = args[n - 1];
        size_t len = strlen(shown);
        snprintf(shown + len, sizeof shown - len, "%s%s", len ? " " : "", args[n - 1]);
    }
    argv[n] = NULL;
    fflush(NULL);
    pid_t pid = fork();
    assert_true(pid >= 0);
    if (pid == 0) {
        int o = open(out_path, O_WRONLY | O_CREAT | O_TRUNC, 0666);
        int e = open(err_path, O_WRONLY | O_CREAT | O_TRUNC, 0666);
        if (o < 0 || e < 0 || dup2(o, 1) < 0 || dup2(e, 2) < 0 || chdir(cwd) != 0)
            _exit(126);
        execv(exe, (char *const *)argv);
        _exit(127);
    }
    int status = 0;
    assert_int_equal(waitpid(pid, &status, 0), pid);
    return collect(exe, tmp_dir, status, shown);
}

void vt_run_free(vt_run_result *r)
{
    free(r->out);
    free(r->err);
}

int vt_tmp_dir_make(char *dir, size_t size, const char *name)
{
    snprintf(dir, size, "/tmp/%s_XXXXXX", name);
    return mkdtemp(dir) ? 0 : -1;
}

int vt_tmp_dir_remove(const char *dir)
{
    char cmd[600];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
    return system(cmd) == 0 ? 0 : -1;
}

int vt_run_setup(void **state, char *dir, size_t size, const char *name, const char *exe)
{
    if (vt_tmp_dir_make(dir, size, name) != 0)
        return -1;
    *state = dir;
    struct stat st;
    if (stat(exe, &st) != 0) {
        printf("the binary is missing: %s\n", exe);
        return -1;
    }
    return 0;
}

int vt_tmp_dir_teardown(void **state)
{
    return *state ? vt_tmp_dir_remove((const char *)*state) : 0;
}

void vt_assert_dir_holds(const char *dir, const char *const *names)
{
    size_t want = 0, found = 0;
    while (names[want])
        ++want;
    DIR *d = opendir(dir);
    assert_non_null(d);
    for (struct dirent *e; (e = readdir(d)) != NULL;) {
        if (strcmp(e->d_name, ".") == 0 || strcmp(e->d_name, "..") == 0)
            continue;
        int known = 0;
        for (size_t i = 0; i < want; ++i)
            known |= strcmp(e->d_name, names[i]) == 0;
        if (!known)
            print_message("%s: unexpected entry '%s'\n", dir, e->d_name);
        assert_true(known);
        ++found;
    }
    closedir(d);
    assert_int_equal(found, want);
}

int vt_make_full_device(const char *path)
{
    return mknod(path, S_IFCHR | 0666, makedev(1, 7)) == 0;
}

int vt_is_full_device(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0 && S_ISCHR(st.st_mode) && major(st.st_rdev) == 1 && minor(st.st_rdev) == 7;
}
