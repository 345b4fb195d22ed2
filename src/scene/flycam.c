/* The interactive cameras of horizon view: see flycam.h. No GL. */
#include "horizon/flycam.h"

#include <math.h>

#define SPEED_MIN 0.1f
#define SPEED_MAX 100000.0f

hz_flycam_desc hz_flycam_desc_defaults(const hz_flycam_desc *desc)
{
    hz_flycam_desc d = desc ? *desc : (hz_flycam_desc){0};
    if (!(d.speed > 0.0f))
        d.speed = 50.0f;
    if (!(d.fast_mul > 0.0f))
        d.fast_mul = 6.0f;
    if (!(d.slow_mul > 0.0f))
        d.slow_mul = 0.15f;
    if (!(d.eye_height > 0.0f))
        d.eye_height = 1.8f;
    if (d.clearance == 0.0f)
        d.clearance = 1.0f;
    if (!(d.pitch_limit > 0.0f) || d.pitch_limit > 89.9f)
        d.pitch_limit = 89.0f;
    return d;
}

float hz_flycam_ground(const hz_flycam *fc)
{
    if (!fc->height)
        return NAN;
    return fc->height(fc->height_user, fc->cam.pos[0], fc->cam.pos[2]);
}

/* Viewer only: walk mode pins the eye to ground + eye_height; otherwise the
 * eye stays at least `clearance` above the ground. */
static void clamp_to_ground(hz_flycam *fc)
{
    if (fc->mode != HZ_FLYCAM_VIEWER || !fc->height)
        return;
    float g = hz_flycam_ground(fc);
    if (!isfinite(g))
        return;
    if (fc->walk)
        fc->cam.pos[1] = g + fc->eye_height;
    else if (fc->clearance >= 0.0f && fc->cam.pos[1] < g + fc->clearance)
        fc->cam.pos[1] = g + fc->clearance;
}

void hz_flycam_init(hz_flycam *fc, const hz_flycam_desc *desc)
{
    HZ_ASSERT(fc);
    hz_flycam_desc d = hz_flycam_desc_defaults(desc);
    fc->cam = d.start;
    fc->mode = d.mode;
    fc->walk = d.walk && d.mode == HZ_FLYCAM_VIEWER;
    fc->speed = d.speed < SPEED_MIN ? SPEED_MIN : d.speed > SPEED_MAX ? SPEED_MAX : d.speed;
    fc->fast_mul = d.fast_mul;
    fc->slow_mul = d.slow_mul;
    fc->eye_height = d.eye_height;
    fc->clearance = d.clearance;
    fc->pitch_limit = d.pitch_limit;
    fc->height = d.height;
    fc->height_user = d.height_user;
    fc->cam.pitch = glm_clamp(fc->cam.pitch, -fc->pitch_limit, fc->pitch_limit);
    clamp_to_ground(fc);
}

void hz_flycam_basis(const hz_flycam *fc, vec3 forward, vec3 right, vec3 up)
{
    const float y = glm_rad(fc->cam.yaw);
    /* yaw 0 -> -z, yaw 90 -> +x; right is forward turned 90 degrees clockwise
     * seen from above, the same as camera.c's frustum basis. */
    right[0] = cosf(y);
    right[1] = 0.0f;
    right[2] = sinf(y);
    if (fc->mode == HZ_FLYCAM_FREE) {
        hz_camera_forward(&fc->cam, forward);
        glm_vec3_cross(right, forward, up);
        glm_vec3_normalize(up);
    } else {
        forward[0] = sinf(y);
        forward[1] = 0.0f;
        forward[2] = -cosf(y);
        up[0] = 0.0f;
        up[1] = 1.0f;
        up[2] = 0.0f;
    }
}

void hz_flycam_update(hz_flycam *fc, const hz_flycam_input *in, float dt)
{
    HZ_ASSERT(fc && in);
    /* Look. */
    if (isfinite(in->yaw_deg))
        fc->cam.yaw = fmodf(fc->cam.yaw + in->yaw_deg, 360.0f);
    if (fc->cam.yaw < 0.0f)
        fc->cam.yaw += 360.0f;
    if (isfinite(in->pitch_deg))
        fc->cam.pitch += in->pitch_deg;
    fc->cam.pitch = glm_clamp(fc->cam.pitch, -fc->pitch_limit, fc->pitch_limit);

    /* Move. */
    if (dt > 0.0f && isfinite(dt)) {
        float speed = fc->speed;
        if (in->fast)
            speed *= fc->fast_mul;
        else if (in->slow)
            speed *= fc->slow_mul;
        const float step = speed * dt;
        const float fwd = glm_clamp(in->forward, -1.0f, 1.0f);
        const float rgt = glm_clamp(in->right, -1.0f, 1.0f);
        float upv = glm_clamp(in->up, -1.0f, 1.0f);
        vec3 f, r, u;
        hz_flycam_basis(fc, f, r, u);
        if (fc->mode == HZ_FLYCAM_VIEWER && fc->walk) {
            /* Walking: Q/E change the eye height, not the position. */
            fc->eye_height = fmaxf(0.1f, fc->eye_height + upv * step);
            upv = 0.0f;
        }
        vec3 d = {0.0f, 0.0f, 0.0f};
        glm_vec3_muladds(f, fwd, d);
        glm_vec3_muladds(r, rgt, d);
        glm_vec3_muladds(u, upv, d);
        /* Diagonals are not faster than straight moves. */
        float len = glm_vec3_norm(d);
        if (len > 1.0f)
            glm_vec3_scale(d, 1.0f / len, d);
        glm_vec3_muladds(d, step, fc->cam.pos);
    }
    clamp_to_ground(fc);
}

void hz_flycam_set_mode(hz_flycam *fc, hz_flycam_mode mode)
{
    HZ_ASSERT(fc);
    fc->mode = mode;
    if (mode != HZ_FLYCAM_VIEWER)
        fc->walk = false;
    clamp_to_ground(fc);
}

void hz_flycam_set_walk(hz_flycam *fc, bool walk)
{
    HZ_ASSERT(fc);
    if (fc->mode != HZ_FLYCAM_VIEWER)
        return;
    fc->walk = walk;
    clamp_to_ground(fc);
}

float hz_flycam_scroll_speed(hz_flycam *fc, float notches)
{
    HZ_ASSERT(fc);
    if (isfinite(notches))
        fc->speed *= powf(1.25f, notches);
    fc->speed = glm_clamp(fc->speed, SPEED_MIN, SPEED_MAX);
    return fc->speed;
}

void hz_flycam_view(const hz_flycam *fc, mat4 dest)
{
    hz_camera_view(&fc->cam, dest);
}

const char *hz_flycam_mode_name(const hz_flycam *fc)
{
    if (fc->mode == HZ_FLYCAM_FREE)
        return "free";
    return fc->walk ? "walk" : "viewer";
}
