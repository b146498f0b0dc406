/* timer.c — a monotonic clock and the order statistics of timing samples. */
#define _POSIX_C_SOURCE 200809L

#include "timer.h"

#include <math.h>
#include <stdlib.h>
#include <time.h>

double vc_now_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec * 1e3 + (double)ts.tv_nsec * 1e-6;
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

double vc_median(double *v, size_t n)
{
    if (n == 0)
        return 0.0;
    qsort(v, n, sizeof *v, cmp_double);
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

double vc_percentile(double *v, size_t n, double p)
{
    if (n == 0)
        return 0.0;
    qsort(v, n, sizeof *v, cmp_double);
    /* Nearest rank: the smallest sample with at least p% of the samples at or below it. */
    double rank = ceil(p / 100.0 * (double)n);
    size_t i = rank < 1.0 ? 0 : (size_t)rank - 1;
    return v[i < n ? i : n - 1];
}

double vc_min(const double *v, size_t n)
{
    double m = n ? v[0] : 0.0;
    for (size_t i = 1; i < n; ++i)
        if (v[i] < m)
            m = v[i];
    return m;
}

double vc_max(const double *v, size_t n)
{
    double m = n ? v[0] : 0.0;
    for (size_t i = 1; i < n; ++i)
        if (v[i] > m)
            m = v[i];
    return m;
}

double vc_mrays_per_s(double rays, double ms)
{
    return ms > 0.0 ? rays / (ms * 1e3) : 0.0;
}
