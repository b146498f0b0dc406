/* fly.c — the viewer's camera: matrices in double (the engine's form that libvis takes
 * through vis_camera_from_matrices), fly and orbit motion. */
#include "viewer.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static void normalize3(double v[3])
{
    double l = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    if (l > 0.0)
        v[0] /= l, v[1] /= l, v[2] /= l;
}

static void cross3(const double a[3], const double b[3], double o[3])
{
    o[0] = a[1] * b[2] - a[2] * b[1];
    o[1] = a[2] * b[0] - a[0] * b[2];
    o[2] = a[0] * b[1] - a[1] * b[0];
}

void vv_look_at(const vv_view *v, vv_mat4 *out)
{
    double f[3] = {v->target[0] - v->eye[0], v->target[1] - v->eye[1], v->target[2] - v->eye[2]}, s[3], u[3];
    normalize3(f);
    const double up_y[3] = {0, 1, 0}, up_z[3] = {0, 0, -1};
    cross3(f, up_y, s);
    if (s[0] == 0.0 && s[1] == 0.0 && s[2] == 0.0)
        cross3(f, up_z, s);
    normalize3(s);
    cross3(s, f, u);
    double *m = out->m;
    memset(m, 0, sizeof out->m);
    for (int c = 0; c < 3; ++c) {
        m[c * 4 + 0] = s[c];
        m[c * 4 + 1] = u[c];
        m[c * 4 + 2] = -f[c];
    }
    const double *e = v->eye;
    m[12] = -(s[0] * e[0] + s[1] * e[1] + s[2] * e[2]);
    m[13] = -(u[0] * e[0] + u[1] * e[1] + u[2] * e[2]);
    m[14] = f[0] * e[0] + f[1] * e[1] + f[2] * e[2];
    m[15] = 1.0;
}

void vv_perspective(double fovy_deg, double aspect, double n, double f, vv_mat4 *out)
{
    double th = tan(fovy_deg * 0.5 * (3.14159265358979323846 / 180.0));
    double *m = out->m;
    memset(m, 0, sizeof out->m);
    m[0] = 1.0 / (aspect * th);
    m[5] = 1.0 / th;
    m[11] = -1.0;
    if (f == 0.0) {
        m[10] = -1.0;
        m[14] = -2.0 * n;
    } else {
        m[10] = -(f + n) / (f - n);
        m[14] = -(2.0 * f * n) / (f - n);
    }
}

void vv_mat4_mul(const vv_mat4 *a, const vv_mat4 *b, vv_mat4 *out)
{
    vv_mat4 r;
    for (int c = 0; c < 4; ++c)
        for (int row = 0; row < 4; ++row) {
            double s = 0.0;
            for (int k = 0; k < 4; ++k)
                s += a->m[k * 4 + row] * b->m[c * 4 + k];
            r.m[c * 4 + row] = s;
        }
    *out = r;
}

void vv_view_local(const vv_view *v, const double origin[3], vv_view *out)
{
    *out = *v;
    for (int a = 0; a < 3; ++a) {
        out->eye[a] -= origin[a];
        out->target[a] -= origin[a];
    }
}

/* Forward (unit), and the horizontal right axis. */
static void basis(const vv_view *v, double f[3], double r[3], double *dist)
{
    for (int a = 0; a < 3; ++a)
        f[a] = v->target[a] - v->eye[a];
    *dist = sqrt(f[0] * f[0] + f[1] * f[1] + f[2] * f[2]);
    normalize3(f);
    const double up_y[3] = {0, 1, 0};
    cross3(f, up_y, r);
    normalize3(r);
}

void vv_fly_move(vv_view *v, double forward, double right, double up)
{
    double f[3], r[3], d;
    basis(v, f, r, &d);
    for (int a = 0; a < 3; ++a) {
        double step = f[a] * forward + r[a] * right + (a == 1 ? up : 0.0);
        v->eye[a] += step;
        v->target[a] += step;
    }
}

/* Yaw about +Y and pitch (clamped short of straight up/down) of a direction. */
static void turn_dir(double f[3], double yaw, double pitch)
{
    double h = sqrt(f[0] * f[0] + f[2] * f[2]);
    double az = atan2(f[2], f[0]) + yaw;
    double el = atan2(f[1], h) + pitch;
    const double lim = 1.55;
    el = el > lim ? lim : el < -lim ? -lim : el;
    f[0] = cos(el) * cos(az);
    f[1] = sin(el);
    f[2] = cos(el) * sin(az);
}

void vv_fly_turn(vv_view *v, double yaw, double pitch)
{
    double f[3], r[3], d;
    basis(v, f, r, &d);
    turn_dir(f, yaw, pitch);
    if (!(d > 1.0))
        d = 1.0;
    for (int a = 0; a < 3; ++a)
        v->target[a] = v->eye[a] + f[a] * d;
}

void vv_orbit(vv_view *v, double yaw, double pitch, double zoom)
{
    double f[3], r[3], d;
    basis(v, f, r, &d);
    turn_dir(f, yaw, pitch);
    d *= zoom;
    if (d < 2.0)
        d = 2.0;
    for (int a = 0; a < 3; ++a)
        v->eye[a] = v->target[a] - f[a] * d;
}

int vv_view_parse(const char *s, vv_view *out)
{
    double v[7];
    int n = 0, done = 0;
    const char *p = s;
    while (n < 7 && !done) {
        char *end;
        v[n] = strtod(p, &end);
        if (end == p || !isfinite(v[n]))
            return -1;
        ++n;
        if (*end == '\0')
            done = 1;
        else if (*end != ',')
            return -1;
        p = end + 1;
    }
    if (!done || (n != 6 && n != 7))
        return -1;
    for (int a = 0; a < 3; ++a) {
        out->eye[a] = v[a];
        out->target[a] = v[3 + a];
    }
    out->fovy_deg = n == 7 ? v[6] : 60.0;
    if (!(out->fovy_deg > 0.0 && out->fovy_deg < 180.0))
        return -1;
    return 0;
}
