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
    float earth_radius; /* metres; 0 -> a flat world. > 0: Earth curvature, every world
                           point is drawn lowered by hz_curvature_drop (d^2 / 2R, d its
                           horizontal distance from the eye): shaders, LOD bounds, culling,
                           picking and metrics all take it from here. < 0: the world bends
                           up, as a camera mirrored at a water plane sees it (hz_camera_mirror_y) */
} hz_camera;

/* Mean Earth radius (IUGG R1), metres. */
#define HZ_EARTH_RADIUS 6371008.8
/* --curvature auto: on when the terrain's side exceeds this, metres. */
#define HZ_CURVATURE_AUTO_EXTENT 50000.0f

typedef enum hz_curvature_mode {
    HZ_CURVATURE_AUTO = 0, /* on above HZ_CURVATURE_AUTO_EXTENT */
    HZ_CURVATURE_ON,
    HZ_CURVATURE_OFF
} hz_curvature_mode;

/* How far below the flat world a point at horizontal offset (dx, dz) metres
 * from the eye is drawn on a sphere of radius metres: (dx^2 + dz^2) / (2 radius),
 * the parabolic approximation of the sphere (within 0.2 % of its sagitta up to 500 km).
 * 0 when radius is 0 (flat), negative for a negative radius (mirrored). The one formula the CPU uses (the GLSL twin is
 * shaders/curvature.glsl). */
static inline float hz_curvature_drop(float radius, float dx, float dz)
{
    return radius != 0.0f ? (dx * dx + dz * dz) / (2.0f * radius) : 0.0f;
}
/* hz_curvature_drop of world point (x, z) seen from cam's eye. */
static inline float hz_camera_drop(const hz_camera *cam, float x, float z)
{
    return hz_curvature_drop(cam->earth_radius, x - cam->pos[0], z - cam->pos[2]);
}
/* Lowers a world box (box[0] min, box[1] max corner) so that it holds the
 * curved image of everything inside it: min y by the largest drop over its
 * xz rectangle (the farthest corner), max y by the smallest (the nearest
 * point); a negative radius raises it the same way. Nothing when
 * cam->earth_radius is 0. O(1). */
void hz_camera_curve_box(const hz_camera *cam, float box[2][3]);
/* The same for a sphere (world centre c, radius r): c moves down by its drop
 * and the radius grows by how much the drop varies over the sphere, so the
 * result holds the sphere's curved image. Nothing on a flat world. */
void hz_camera_curve_sphere(const hz_camera *cam, float c[3], float *r);
/* The radius --curvature uses for a terrain of side `extent` metres: 0 (flat)
 * for off, or for auto at or below HZ_CURVATURE_AUTO_EXTENT; else radius
 * (0 -> HZ_EARTH_RADIUS). */
float hz_curvature_radius(hz_curvature_mode mode, float extent, float radius);
/* The Gaussian radius of curvature sqrt(M N) of the WGS84 ellipsoid at
 * latitude lat_deg (degrees), metres: 6 356 752 at the equator, 6 399 594 at the poles. */
double hz_wgs84_radius(double lat_deg);

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
 * reflected, pitch negated, earth_radius negated): it sees exactly what a water plane reflects, for
 * LOD selection and culling of the reflection pass. */
void hz_camera_mirror_y(const hz_camera *c, float plane_y, hz_camera *dest);

/* Ground height (metres) at world (x, z), for the helpers below. */
typedef float (*hz_ground_fn)(void *user, float x, float z);

/* A first view of a place: its summit focus (x, z, height) seen from 3x the
 * relief away (within 8 - 35 % of the shorter side of rect, the data's
 * world rectangle x0, z0, x1, z1), back toward centre (the data's middle; a
 * summit near it is seen from the south-south-west), above the summit and
 * the ground under the eye (ground), looking a little below the summit.
 * Field of view 60 degrees, far plane 1.5 x extent. */
hz_camera hz_camera_summit_view(const float rect[4], const float centre[2], const float focus[3], float relief,
                                float extent, hz_ground_fn ground, void *user, uint32_t width, uint32_t height);

#ifdef __cplusplus
}
#endif
#endif
