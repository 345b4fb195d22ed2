/* Picking: camera pixel rays, ray against the terrain's surface, and the
 * nearest of terrain and scene. */
#include "horizon/pick.h"

#include <math.h>

void hz_camera_pixel_ray(const hz_camera *cam, float x, float y, uint32_t w, uint32_t h, float origin[3],
                         float dir[3])
{
    mat4 vp, inv;
    hz_camera_viewproj(cam, vp);
    glm_mat4_inv(vp, inv);
    float nx = 2.0f * x / (float)w - 1.0f, ny = 1.0f - 2.0f * y / (float)h;
    vec4 a, b;
    glm_mat4_mulv(inv, (vec4){nx, ny, -1, 1}, a);
    glm_mat4_mulv(inv, (vec4){nx, ny, 1, 1}, b);
    vec3 pa, pb;
    glm_vec3_scale(a, 1.0f / a[3], pa);
    glm_vec3_scale(b, 1.0f / b[3], pb);
    glm_vec3_sub(pb, pa, dir);
    glm_vec3_normalize(dir);
    glm_vec3_copy(pa, origin);
}

static float above(const hz_terrain *t, const float o[3], const float d[3], float s)
{
    return o[1] + s * d[1] - hz_terrain_surface_at(t, o[0] + s * d[0], o[2] + s * d[2]);
}

static bool on_map(const hz_terrain *t, const float o[3], const float d[3], float s)
{
    const float e = hz_terrain_extent(t), x = o[0] + s * d[0], z = o[2] + s * d[2];
    return x >= 0 && z >= 0 && x <= e && z <= e;
}

bool hz_terrain_raycast(const hz_terrain *t, const float origin[3], const float dir[3], float t_max, float *t_hit)
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
    float prev = s0, fprev = above(t, origin, dir, s0);
    if (fprev <= 0) {
        if (s0 == 0)
            return false; /* the origin is under the ground */
        *t_hit = s0;      /* enters the map below its edge: the edge wall */
        return true;
    }
    for (float s = s0 + step; prev < s1; s += step) {
        if (s > s1)
            s = s1;
        float f = above(t, origin, dir, s);
        if (f <= 0 && on_map(t, origin, dir, s)) {
            float lo = prev, hi = s;
            for (int it = 0; it < 40; it++) {
                float mid = 0.5f * (lo + hi);
                if (above(t, origin, dir, mid) > 0)
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

hz_pick_result hz_pick(const hz_terrain *t, const hz_scene *s, const hz_camera *cam, float x, float y, uint32_t w,
                       uint32_t h)
{
    hz_pick_result r = {.node = HZ_NODE_NONE};
    float o[3], d[3];
    hz_camera_pixel_ray(cam, x, y, w, h, o, d);
    const float far = cam->zfar > 0 ? cam->zfar : 100000.0f;
    float best = far * 1.5f; /* the far plane is a distance along the axis; corners reach farther */
    float tt;
    if (t && hz_terrain_raycast(t, o, d, best, &tt)) {
        best = tt;
        r.hit = r.terrain = true;
    }
    hz_scene_hit sh;
    if (s && hz_scene_raycast(s, o, d, best, &sh)) {
        best = sh.t;
        r.hit = true;
        r.terrain = false;
        r.node = sh.node;
    }
    if (r.hit) {
        for (int k = 0; k < 3; k++)
            r.pos[k] = o[k] + best * d[k];
        r.distance = best;
    }
    return r;
}
