/* horizon picking: what is under a pixel, the nearest of the terrain's
 * surface and a scene's mesh triangles. No GL. */
#ifndef HORIZON_PICK_H
#define HORIZON_PICK_H

#include "horizon/camera.h"
#include "horizon/scene.h"
#include "horizon/terrain.h"

#ifdef __cplusplus
extern "C" {
#endif

/* The ray of pixel (x, y) of cam's w x h image (x right, y down from the
 * top-left corner; pixel centres at +0.5): origin on the near plane, unit
 * direction, world space. */
void hz_camera_pixel_ray(const hz_camera *cam, float x, float y, uint32_t w, uint32_t h, float origin[3],
                         float dir[3]);

/* Intersection of a ray with the terrain's full-resolution surface (the
 * triangles hz_terrain_surface_at interpolates, as the reference mesh
 * draws them; masked samples included), nearest t in (0, t_max], marched
 * a quarter cell at a time and refined by bisection on the piecewise-linear
 * surface. False when the ray leaves the map or reaches t_max first. */
bool hz_terrain_raycast(const hz_terrain *t, const float origin[3], const float dir[3], float t_max, float *t_hit);
/* hz_terrain_raycast against the surface as drawn for cam: lowered by the
 * Earth curvature (hz_camera_drop; the same as hz_terrain_raycast when
 * cam->earth_radius is 0). The ray is in world space as drawn. */
bool hz_terrain_raycast_curved(const hz_terrain *t, const hz_camera *cam, const float origin[3], const float dir[3],
                               float t_max, float *t_hit);

typedef struct hz_pick_result {
    bool hit;
    bool terrain;        /* the terrain is nearest (node = HZ_NODE_NONE) */
    uint32_t node;       /* the scene node hit, else HZ_NODE_NONE */
    float pos[3];        /* world metres, on the map (flat world: y is the height there) */
    float distance;      /* from the ray origin, metres */
    float drop;          /* Earth curvature: the point is drawn this far below pos (world
                            y - drop, hz_camera_drop); 0 on a flat world */
} hz_pick_result;

/* Picks pixel (x, y): scene may be NULL (terrain only), t may be NULL
 * (scene only). The scene must be updated (hz_scene_update). With
 * cam->earth_radius > 0 it picks what is drawn there on the curved world
 * (pos on the map, drop how far below it the pixel shows it). */
hz_pick_result hz_pick(const hz_terrain *t, const hz_scene *s, const hz_camera *cam, float x, float y, uint32_t w,
                       uint32_t h);

#ifdef __cplusplus
}
#endif
#endif
