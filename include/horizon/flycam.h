/* horizon flycam (SPEC R8): the two interactive cameras of `horizon view`,
 * as plain maths over hz_camera. No GL, no window: input arrives as numbers,
 * so the behaviour is unit-tested without a display.
 *
 *  - viewer camera: fixed up axis (+y), yaw + pitch. W/S move horizontally
 *    along the yaw direction (looking down does not dive), A/D strafe, Q/E
 *    move along +-y. It never goes below the ground + `clearance`. In walk
 *    mode the eye is kept exactly `eye_height` above the ground and Q/E raise
 *    or lower that height instead.
 *  - free camera: moves along its full view direction (pitch included), A/D
 *    along its right vector, Q/E along its own up vector; no ground clamp.
 *
 * World: y up, metres; yaw 0 looks toward -z, yaw 90 toward +x; pitch > 0
 * looks up (the conventions of camera.h). */
#ifndef HORIZON_FLYCAM_H
#define HORIZON_FLYCAM_H

#include "horizon/camera.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Ground height in world metres (zscale applied) at world (x, z). */
typedef float (*hz_height_fn)(void *user, float x, float z);

typedef enum hz_flycam_mode {
    HZ_FLYCAM_VIEWER = 0, /* fixed up axis, optional walk mode (default) */
    HZ_FLYCAM_FREE
} hz_flycam_mode;

typedef struct hz_flycam_desc {
    hz_camera start;        /* initial pose and projection (copied) */
    hz_flycam_mode mode;    /* 0 -> viewer */
    bool walk;              /* viewer only: start in walk mode */
    float speed;            /* base speed, metres per second; 0 -> 50 */
    float fast_mul;         /* speed multiplier while "fast" (shift); 0 -> 6 */
    float slow_mul;         /* speed multiplier while "slow" (ctrl); 0 -> 0.15 */
    float eye_height;       /* walk mode: metres above the ground; 0 -> 1.8 */
    float clearance;        /* viewer (not walking): minimum metres above the ground;
                               0 -> 1, < 0 -> no clamp */
    float pitch_limit;      /* degrees, |pitch| <= limit; 0 -> 89 */
    hz_height_fn height;    /* optional ground; without it walk mode and the
                               clearance do nothing */
    void *height_user;      /* passed to height */
} hz_flycam_desc;

typedef struct hz_flycam {
    hz_camera cam;          /* the current camera; pos/yaw/pitch change, the
                               projection fields are left alone */
    hz_flycam_mode mode;
    bool walk;
    float speed, fast_mul, slow_mul, eye_height, clearance, pitch_limit;
    hz_height_fn height;
    void *height_user;
} hz_flycam;

/* One frame of input, already in camera terms. */
typedef struct hz_flycam_input {
    float forward;          /* +1 = W, -1 = S (any value in [-1, 1]) */
    float right;            /* +1 = D, -1 = A */
    float up;               /* +1 = E, -1 = Q */
    float yaw_deg;          /* look delta this frame, degrees (+ turns right) */
    float pitch_deg;        /* look delta this frame, degrees (+ looks up) */
    bool fast;              /* shift held */
    bool slow;              /* ctrl held */
} hz_flycam_input;

/* Zero fields -> the defaults listed in hz_flycam_desc. */
hz_flycam_desc hz_flycam_desc_defaults(const hz_flycam_desc *desc);

/* Initialises fc from desc (defaults applied) and applies the ground clamp
 * once, so the first frame already satisfies walk mode / clearance. */
void hz_flycam_init(hz_flycam *fc, const hz_flycam_desc *desc);

/* Advances one frame of dt seconds: look first (yaw wraps to [0, 360),
 * pitch is clamped to +-pitch_limit), then moves at speed * (fast_mul |
 * slow_mul) metres per second along the mode's basis, then clamps to the
 * ground (viewer only). dt <= 0 only applies the look. */
void hz_flycam_update(hz_flycam *fc, const hz_flycam_input *in, float dt);

/* Movement basis of the current mode, unit vectors, world space. Viewer:
 * forward is horizontal, up is +y. Free: forward is the view direction, up
 * is the camera's up (right x forward). right is horizontal in both. */
void hz_flycam_basis(const hz_flycam *fc, vec3 forward, vec3 right, vec3 up);

/* Switches camera mode keeping position and orientation; switching to the
 * viewer applies its ground clamp. */
void hz_flycam_set_mode(hz_flycam *fc, hz_flycam_mode mode);

/* Walk mode on/off (viewer only; ignored in free mode). */
void hz_flycam_set_walk(hz_flycam *fc, bool walk);

/* Scroll: speed *= 1.25^notches, kept in [0.1, 100000] m/s. Returns the
 * new speed. */
float hz_flycam_scroll_speed(hz_flycam *fc, float notches);

/* Ground height under the eye (metres), or NAN without a height function. */
float hz_flycam_ground(const hz_flycam *fc);

/* World -> eye matrix of the current camera (hz_camera_view). */
void hz_flycam_view(const hz_flycam *fc, mat4 dest);

/* "viewer", "walk" or "free". */
const char *hz_flycam_mode_name(const hz_flycam *fc);

#ifdef __cplusplus
}
#endif
#endif
