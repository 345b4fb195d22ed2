/* Picking: camera pixel rays, ray against the terrain's surface, and the
 * nearest of terrain and scene. */
#include "horizon/pick.h"

#include <math.h>
#include <string.h>

void hz_camera_pixel_ray(const hz_camera *cam, float x, float y, uint32_t w, uint32_t h, float origin[3],
                         float dir[3])
{
    /* From the camera's own terms, in double (as hz_camera_view builds its
     * basis): inverting a float view-projection 100 km from the origin with
     * a far plane at 200 km cancelled the far point's w to ~1 %, which turned
     * rays by up to 0.1 degree (picks tens of metres off at 10 km). */
    const double fov = (cam->fov_y > 0 ? cam->fov_y : 60.0) * 3.14159265358979323846 / 360.0;
    const double aspect = cam->aspect > 0 ? cam->aspect : 16.0 / 9.0, n = cam->znear > 0 ? cam->znear : 1.0;
    const double t = tan(fov), xv = (2.0 * x / (double)w - 1.0) * t * aspect, yv = (1.0 - 2.0 * y / (double)h) * t;
    const double pitch = glm_rad(glm_clamp(cam->pitch, -89.9f, 89.9f)), yaw = glm_rad(cam->yaw);
    const double f[3] = {sin(yaw) * cos(pitch), sin(pitch), -cos(yaw) * cos(pitch)};
    const double r[3] = {cos(yaw), 0.0, sin(yaw)};
    const double u[3] = {r[1] * f[2] - r[2] * f[1], r[2] * f[0] - r[0] * f[2], r[0] * f[1] - r[1] * f[0]};
    double d[3], l = 0;
    for (int k = 0; k < 3; k++) {
        d[k] = xv * r[k] + yv * u[k] + f[k]; /* on the view plane one metre ahead */
        l += d[k] * d[k];
    }
    l = sqrt(l);
    for (int k = 0; k < 3; k++) {
        origin[k] = (float)(cam->pos[k] + n * d[k]); /* on the near plane */
        dir[k] = (float)(d[k] / l);
    }
}

/* Height of the ray above the surface as drawn: lowered by the Earth
 * curvature's drop seen from eye (radius 0: flat). */
typedef struct curv_eye {
    float x, z, radius;
} curv_eye;

static float above(const hz_terrain *t, const curv_eye *c, const float o[3], const float d[3], float s)
{
    const float x = o[0] + s * d[0], z = o[2] + s * d[2];
    return o[1] + s * d[1] - (hz_terrain_surface_at(t, x, z) - hz_curvature_drop(c->radius, x - c->x, z - c->z));
}

static bool on_map(const hz_terrain *t, const float o[3], const float d[3], float s)
{
    const float e = hz_terrain_extent(t), x = o[0] + s * d[0], z = o[2] + s * d[2];
    return x >= 0 && z >= 0 && x <= e && z <= e;
}

static bool raycast(const hz_terrain *t, const curv_eye *c, const float origin[3], const float dir[3], float t_max,
                    float *t_hit)
{
    const float step = 0.25f * t->spacing;
    /* Start where the ray enters the map square (slab test in x, z). */
    float s0 = 0, s1 = t_max;
    const float e = hz_terrain_extent(t);
    for (int k = 0; k < 3; k += 2) {
        if (fabsf(dir[k]) < 1e-12f) {
            if (origin[k] < 0 || origin[k] > e)
                return false;
            continue;
        }
        float a = (0 - origin[k]) / dir[k], b = (e - origin[k]) / dir[k];
        s0 = fmaxf(s0, fminf(a, b));
        s1 = fminf(s1, fmaxf(a, b));
    }
    if (s0 > s1)
        return false;
    float prev = s0, fprev = above(t, c, origin, dir, s0);
    if (fprev <= 0) {
        if (s0 == 0)
            return false; /* the origin is under the ground */
        *t_hit = s0;      /* enters the map below its edge: the edge wall */
        return true;
    }
    for (float s = s0 + step; prev < s1; s += step) {
        if (s > s1)
            s = s1;
        float f = above(t, c, origin, dir, s);
        if (f <= 0 && on_map(t, origin, dir, s)) {
            float lo = prev, hi = s;
            for (int it = 0; it < 40; it++) {
                float mid = 0.5f * (lo + hi);
                if (above(t, c, origin, dir, mid) > 0)
                    lo = mid;
                else
                    hi = mid;
            }
            *t_hit = hi;
            return true;
        }
        prev = s;
        fprev = f;
    }
    (void)fprev;
    return false;
}

bool hz_terrain_raycast(const hz_terrain *t, const float origin[3], const float dir[3], float t_max, float *t_hit)
{
    const curv_eye flat = {0, 0, 0};
    return raycast(t, &flat, origin, dir, t_max, t_hit);
}

bool hz_terrain_raycast_curved(const hz_terrain *t, const hz_camera *cam, const float origin[3], const float dir[3],
                               float t_max, float *t_hit)
{
    const curv_eye c = {cam->pos[0], cam->pos[2], cam->earth_radius};
    return raycast(t, &c, origin, dir, t_max, t_hit);
}

/* The scene's meshes are drawn lowered by the curvature too: the straight
 * ray through the drawn world is, in the scene's flat coordinates, raised by
 * the drop at each point (a parabola). Follows it as a polyline of chords
 * short enough to stay within a few cm of it (the sag of a chord of length L
 * is L^2 / (8 R): 2 km -> 8 cm). */
static bool scene_raycast_curved(const hz_scene *s, const hz_camera *cam, const float o[3], const float d[3],
                                 float t_max, hz_scene_hit *hit)
{
    const float chord = 2000.0f;
    float prev[3] = {o[0], o[1] + hz_camera_drop(cam, o[0], o[2]), o[2]};
    for (float u0 = 0; u0 < t_max; u0 += chord) {
        const float u1 = fminf(u0 + chord, t_max);
        const float x = o[0] + u1 * d[0], z = o[2] + u1 * d[2];
        const float next[3] = {x, o[1] + u1 * d[1] + hz_camera_drop(cam, x, z), z};
        const float seg[3] = {next[0] - prev[0], next[1] - prev[1], next[2] - prev[2]};
        if (hz_scene_raycast(s, prev, seg, 1.0f, hit)) {
            hit->t = u0 + hit->t * (u1 - u0);
            return true;
        }
        memcpy(prev, next, sizeof prev);
    }
    return false;
}

hz_pick_result hz_pick(const hz_terrain *t, const hz_scene *s, const hz_camera *cam, float x, float y, uint32_t w,
                       uint32_t h)
{
    hz_pick_result r = {.node = HZ_NODE_NONE};
    float o[3], d[3];
    hz_camera_pixel_ray(cam, x, y, w, h, o, d);
    const float far = cam->zfar > 0 ? cam->zfar : 100000.0f;
    float best = far * 1.5f; /* the far plane is a distance along the axis; corners reach farther */
    float tt;
    if (t && hz_terrain_raycast_curved(t, cam, o, d, best, &tt)) {
        best = tt;
        r.hit = r.terrain = true;
    }
    hz_scene_hit sh;
    if (s && (cam->earth_radius > 0 ? scene_raycast_curved(s, cam, o, d, best, &sh)
                                     : hz_scene_raycast(s, o, d, best, &sh))) {
        best = sh.t;
        r.hit = true;
        r.terrain = false;
        r.node = sh.node;
    }
    if (r.hit) {
        for (int k = 0; k < 3; k++)
            r.pos[k] = o[k] + best * d[k];
        r.distance = best;
        /* Back to the map's coordinates: the point is drawn this far below. */
        r.drop = hz_camera_drop(cam, r.pos[0], r.pos[2]);
        r.pos[1] += r.drop;
    }
    return r;
}
