/* Axis-aligned boxes (hz_box): the helpers the scene graph, its culling and
 * the occlusion buffer share, below all of them. */
#include "horizon/scene.h"

#include <float.h>
#include <math.h>

void hz_box_empty(hz_box *b)
{
    glm_vec3_fill(b->min, FLT_MAX);
    glm_vec3_fill(b->max, -FLT_MAX);
}

bool hz_box_is_empty(const hz_box *b)
{
    return b->min[0] > b->max[0] || b->min[1] > b->max[1] || b->min[2] > b->max[2];
}

void hz_box_add_point(hz_box *b, const float p[3])
{
    for (int k = 0; k < 3; k++) {
        b->min[k] = fminf(b->min[k], p[k]);
        b->max[k] = fmaxf(b->max[k], p[k]);
    }
}

float hz_box_distance2(const hz_box *b, const float p[3])
{
    float d2 = 0;
    for (int c = 0; c < 3; c++) {
        const float v = fmaxf(fmaxf(b->min[c] - p[c], p[c] - b->max[c]), 0.0f);
        d2 += v * v;
    }
    return d2;
}

void hz_box_add_box(hz_box *b, const hz_box *o)
{
    if (hz_box_is_empty(o))
        return;
    hz_box_add_point(b, o->min);
    hz_box_add_point(b, o->max);
}

void hz_box_transform(const hz_box *b, const mat4 m, hz_box *dest)
{
    hz_box r;
    hz_box_empty(&r);
    if (!hz_box_is_empty(b)) {
        /* Arvo: the box of a transformed box from the matrix's columns. */
        for (int k = 0; k < 3; k++) {
            r.min[k] = r.max[k] = m[3][k];
            for (int c = 0; c < 3; c++) {
                float a = m[c][k] * b->min[c], e = m[c][k] * b->max[c];
                r.min[k] += fminf(a, e);
                r.max[k] += fmaxf(a, e);
            }
        }
    }
    *dest = r;
}

int hz_box_vs_planes(const hz_box *b, const vec4 *planes, uint32_t plane_count)
{
    if (hz_box_is_empty(b))
        return -1;
    int res = 1;
    for (uint32_t k = 0; k < plane_count; k++) {
        const float *p = planes[k];
        /* The corner farthest along the normal, and the nearest. */
        float far = p[3], near = p[3];
        for (int c = 0; c < 3; c++) {
            far += p[c] * (p[c] >= 0 ? b->max[c] : b->min[c]);
            near += p[c] * (p[c] >= 0 ? b->min[c] : b->max[c]);
        }
        if (far < 0)
            return -1;
        if (near < 0)
            res = 0;
    }
    return res;
}

bool hz_box_around_eye(const hz_box *b, const hz_camera *cam)
{
    const float m = 2.0f * (cam->znear > 0 ? cam->znear : 1.0f);
    for (int c = 0; c < 3; c++)
        if (!(cam->pos[c] > b->min[c] - m && cam->pos[c] < b->max[c] + m))
            return false;
    return true;
}
