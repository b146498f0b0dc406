/* timer.h — wall-clock timing and the order statistics the tools report. */
#ifndef VIS_TOOLS_TIMER_H
#define VIS_TOOLS_TIMER_H

#include <stddef.h>

/* Milliseconds on a monotonic clock (CLOCK_MONOTONIC); only differences mean anything. */
double vc_now_ms(void);

/* Order statistics of n samples; each sorts `v` in place. n == 0 gives 0. */
double vc_median(double *v, size_t n);
/* p in [0, 100]: the nearest-rank percentile (p = 99 is the 99th percentile). */
double vc_percentile(double *v, size_t n, double p);
double vc_min(const double *v, size_t n);
double vc_max(const double *v, size_t n);

/* Millions of rays per second for `rays` rays in `ms` milliseconds (0 when ms <= 0). */
double vc_mrays_per_s(double rays, double ms);

#endif
