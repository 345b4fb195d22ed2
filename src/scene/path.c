#define _POSIX_C_SOURCE 200809L
#include "horizon/path.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

void hz_path_free(hz_path *p)
{
    if (!p)
        return;
    free(p->keys);
    memset(p, 0, sizeof *p);
}

/* Times (s), coordinates (m) and angles (degrees): the range of --camera. */
#define HZ_PATH_MAX_ABS 1e7

hz_result hz_path_from_keys(const hz_path_key *keys, size_t count, const char *name, hz_path *out,
                            hz_err *err)
{
    memset(out, 0, sizeof *out);
    if (count < 2)
        return hz_err_set(err, HZ_ERR_VALUE, "path '%s': needs at least 2 keyframes (got %zu)", name, count);
    for (size_t i = 0; i < count; i++) {
        const hz_path_key *k = &keys[i];
        if (!isfinite(k->t) || !isfinite(k->x) || !isfinite(k->y) || !isfinite(k->z) || !isfinite(k->yaw) ||
            !isfinite(k->pitch))
            return hz_err_set(err, HZ_ERR_VALUE, "path '%s': keyframe %zu is not finite", name, i + 1);
        const float v[6] = {k->t, k->x, k->y, k->z, k->yaw, k->pitch};
        for (int c = 0; c < 6; c++)
            if (fabsf(v[c]) > HZ_PATH_MAX_ABS)
                return hz_err_set(err, HZ_ERR_VALUE,
                                  "path '%s': keyframe %zu: %g is out of range: times, metres and degrees must lie "
                                  "in [-1e7, 1e7] (as for --camera)",
                                  name, i + 1, (double)v[c]);
        if (i && !(k->t > keys[i - 1].t))
            return hz_err_set(err, HZ_ERR_VALUE, "path '%s': time must increase (keyframe %zu: %g after %g)",
                              name, i + 1, (double)k->t, (double)keys[i - 1].t);
    }
    out->keys = malloc(count * sizeof *out->keys);
    if (!out->keys)
        return hz_err_set(err, HZ_ERR_MEMORY, "path: out of memory");
    memcpy(out->keys, keys, count * sizeof *keys);
    out->count = count;
    snprintf(out->name, sizeof out->name, "%s", name);
    return HZ_OK;
}

hz_result hz_path_load_csv(const char *file, hz_path *out, hz_err *err)
{
    memset(out, 0, sizeof *out);
    FILE *f = fopen(file, "r");
    if (!f)
        return hz_err_set(err, HZ_ERR_IO, "cannot open path '%s': %s", file, strerror(errno));
    hz_path_key *keys = NULL;
    size_t n = 0, cap = 0, line_no = 0;
    char line[1024];
    hz_result r = HZ_OK;
    while (fgets(line, sizeof line, f)) {
        line_no++;
        char *s = line;
        while (*s == ' ' || *s == '\t')
            s++;
        if (*s == '#' || *s == '\n' || *s == '\r' || *s == 0)
            continue;
        float v[6];
        int k = 0;
        char *p = s, *end;
        for (; k < 6; k++) {
            errno = 0;
            double d = strtod(p, &end);
            if (end == p || errno)
                break;
            if (!(fabs(d) <= HZ_PATH_MAX_ABS)) { /* also keeps the float conversion defined */
                r = hz_err_set(err, HZ_ERR_VALUE,
                               "path '%s' line %zu: %g is out of range: times, metres and degrees must lie in "
                               "[-1e7, 1e7] (as for --camera)",
                               file, line_no, d);
                goto done;
            }
            v[k] = (float)d;
            p = end;
            while (*p == ' ' || *p == '\t')
                p++;
            if (k < 5) {
                if (*p != ',')
                    break;
                p++;
            }
        }
        while (*p == ' ' || *p == '\t' || *p == '\r' || *p == '\n')
            p++;
        if (k != 6 || *p) {
            if (n == 0 && line_no == 1 && (s[0] < '0' || s[0] > '9') && s[0] != '-' && s[0] != '.')
                continue; /* header */
            r = hz_err_set(err, HZ_ERR_FORMAT, "path '%s' line %zu: expected t,x,y,z,yaw,pitch", file, line_no);
            goto done;
        }
        if (n == cap) {
            cap = cap ? 2 * cap : 64;
            hz_path_key *nk = realloc(keys, cap * sizeof *keys);
            if (!nk) {
                r = hz_err_set(err, HZ_ERR_MEMORY, "path: out of memory");
                goto done;
            }
            keys = nk;
        }
        keys[n++] = (hz_path_key){v[0], v[1], v[2], v[3], v[4], v[5]};
    }
    {
        const char *b = strrchr(file, '/');
        r = hz_path_from_keys(keys, n, b ? b + 1 : file, out, err);
    }
done:
    free(keys);
    fclose(f);
    return r;
}

float hz_path_duration(const hz_path *p)
{
    return p->count ? p->keys[p->count - 1].t - p->keys[0].t : 0.0f;
}

static float catmull(float p0, float p1, float p2, float p3, float u)
{
    float u2 = u * u, u3 = u2 * u;
    return 0.5f * (2.0f * p1 + (-p0 + p2) * u + (2.0f * p0 - 5.0f * p1 + 4.0f * p2 - p3) * u2 +
                   (-p0 + 3.0f * p1 - 3.0f * p2 + p3) * u3);
}

void hz_path_sample(const hz_path *p, float t, hz_camera *cam)
{
    const hz_path_key *k = p->keys;
    size_t n = p->count;
    if (t <= k[0].t || n == 1) {
        cam->pos[0] = k[0].x, cam->pos[1] = k[0].y, cam->pos[2] = k[0].z;
        cam->yaw = k[0].yaw, cam->pitch = k[0].pitch;
        return;
    }
    if (t >= k[n - 1].t) {
        cam->pos[0] = k[n - 1].x, cam->pos[1] = k[n - 1].y, cam->pos[2] = k[n - 1].z;
        cam->yaw = k[n - 1].yaw, cam->pitch = k[n - 1].pitch;
        return;
    }
    size_t i = 0;
    while (i + 1 < n && k[i + 1].t <= t)
        i++;
    const hz_path_key *a = &k[i], *b = &k[i + 1];
    const hz_path_key *a0 = i > 0 ? &k[i - 1] : a, *b1 = i + 2 < n ? &k[i + 2] : b;
    float u = (t - a->t) / (b->t - a->t);
    cam->pos[0] = catmull(a0->x, a->x, b->x, b1->x, u);
    cam->pos[1] = catmull(a0->y, a->y, b->y, b1->y, u);
    cam->pos[2] = catmull(a0->z, a->z, b->z, b1->z, u);
    float dyaw = fmodf(b->yaw - a->yaw, 360.0f);
    if (dyaw > 180.0f)
        dyaw -= 360.0f;
    if (dyaw < -180.0f)
        dyaw += 360.0f;
    cam->yaw = a->yaw + u * dyaw;
    cam->pitch = a->pitch + u * (b->pitch - a->pitch);
}
