/* effects_spec.c — the --effects list: parsing and the names of the bits. */
#include "effects_spec.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

int vc_parse_double(const char *s, double *out)
{
    errno = 0;
    char *end;
    double v = strtod(s, &end);
    if (!s[0] || *end || errno || !isfinite(v))
        return -1;
    *out = v;
    return 0;
}

/* The light's three numbers follow "shadows:" across the commas, so the list is split at
 * every comma first and "shadows:" then takes the next two items too. */
int vc_effects_parse(const char *list, vc_effects *out, char *err, size_t err_size)
{
    char buf[256];
    size_t len = strlen(list);
    if (len >= sizeof buf) {
        snprintf(err, err_size, "value too long");
        return -1;
    }
    memcpy(buf, list, len + 1);
    out->bits = 0;
    char *tok[16];
    int nt = 0;
    for (char *p = buf;; ++p) { /* split at the commas, in place */
        if (nt == 16) {
            snprintf(err, err_size, "too many items");
            return -1;
        }
        tok[nt++] = p;
        p = strchr(p, ',');
        if (!p)
            break;
        *p = '\0';
    }
    for (int ti = 0; ti < nt; ++ti) {
        char *t = tok[ti];
        uint32_t bit = 0;
        if (strcmp(t, "see-through") == 0) {
            bit = VIS_EFFECT_SEE_THROUGH;
        } else if (strcmp(t, "reflect") == 0) {
            bit = VIS_EFFECT_REFLECT;
        } else if (strncmp(t, "shadows:", 8) == 0) {
            bit = VIS_EFFECT_SHADOWS;
            const char *num[3] = {t + 8, ti + 1 < nt ? tok[ti + 1] : NULL, ti + 2 < nt ? tok[ti + 2] : NULL};
            ti += 2;
            double l[3];
            for (int i = 0; i < 3; ++i)
                if (!num[i] || vc_parse_double(num[i], &l[i]) != 0) {
                    snprintf(err, err_size, "shadows needs a light direction shadows:DX,DY,DZ (3 finite numbers)");
                    return -1;
                }
            if (l[0] == 0.0 && l[1] == 0.0 && l[2] == 0.0) {
                snprintf(err, err_size, "the light direction must not be zero");
                return -1;
            }
            memcpy(out->light, l, sizeof l);
        } else if (strncmp(t, "fog:", 4) == 0) {
            bit = VIS_EFFECT_FOG;
            double f;
            if (vc_parse_double(t + 4, &f) != 0 || !(f > 0.0)) {
                snprintf(err, err_size, "fog:DIST needs a finite distance > 0, got '%s'", t + 4);
                return -1;
            }
            out->fog = f;
        } else {
            snprintf(err, err_size, "unknown effect '%s' (see-through, reflect, shadows:DX,DY,DZ, fog:DIST)", t);
            return -1;
        }
        if (out->bits & bit) {
            snprintf(err, err_size, "'%s' given twice", t);
            return -1;
        }
        out->bits |= bit;
    }
    if (!out->bits) {
        snprintf(err, err_size, "no effect named");
        return -1;
    }
    return 0;
}

void vc_effects_format(uint32_t bits, char *out, size_t size)
{
    static const struct {
        uint32_t bit;
        const char *name;
    } names[] = {{VIS_EFFECT_SEE_THROUGH, "see-through"},
                 {VIS_EFFECT_REFLECT, "reflect"},
                 {VIS_EFFECT_SHADOWS, "shadows"},
                 {VIS_EFFECT_FOG, "fog"}};
    size_t at = 0;
    if (size)
        out[0] = '\0';
    for (size_t i = 0; i < sizeof names / sizeof names[0]; ++i)
        if ((bits & names[i].bit) && at < size) {
            int k = snprintf(out + at, size - at, "%s%s", at ? "," : "", names[i].name);
            at += k > 0 ? (size_t)k : 0;
        }
}
