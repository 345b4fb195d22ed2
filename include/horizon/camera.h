/* horizon camera: yaw/pitch viewer camera, view/projection matrices and
 * frustum planes. No GL.
 * World: y up; yaw 0 looks toward -z, yaw 90 toward +x; pitch > 0 looks up.
 * Angles in degrees, positions in metres. */
#ifndef HORIZON_CAMERA_H
#define HORIZON_CAMERA_H

#include <cglm/cglm.h>
#include "horizon/core.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct hz_camera {
    vec3 pos;        /* eye, world metres */
    float yaw;       /* degrees */
    float pitch;     /* degrees, clamped to (-89.9, 89.9) when building matrices */
    float fov_y;     /* vertical field of view, degrees; 0 -> 60 */
    float aspect;    /* width / height; 0 -> 16/9 */
    float znear;     /* metres; 0 -> 1 */
    float zfar;      /* metres, also the view distance for culling; 0 -> 100000 */
} hz_camera;

/* Unit view direction. */
void hz_camera_forward(const hz_camera *c, vec3 dest);
/* World -> eye matrix (right-handed, eye looks down -z). */
void hz_camera_view(const hz_camera *c, mat4 dest);
/* OpenGL projection, clip z in [-w, w], near..far. */
void hz_camera_proj(const hz_camera *c, mat4 dest);
/* Reverse-Z projection for rendering with glClipControl(LOWER_LEFT, ZERO_TO_ONE):
 * depth 1 at near, 0 at far. */
void hz_camera_proj_reverse_z(const hz_camera *c, mat4 dest);
/* proj * view (OpenGL convention). */
void hz_camera_viewproj(const hz_camera *c, mat4 dest);
/* Six normalised world-space planes (left, right, bottom, top, near, far),
 * a point p is inside when dot(n, p) + d >= 0 for all (cglm layout). */
void hz_camera_frustum(const hz_camera *c, vec4 planes[6]);

/* The camera mirrored at the horizontal plane y = plane_y (eye height
 * reflected, pitch negated): it sees exactly what a water plane reflects, for
 * LOD selection and culling of the reflection pass. */
void hz_camera_mirror_y(const hz_camera *c, float plane_y, hz_camera *dest);

#ifdef __cplusplus
}
#endif
#endif
