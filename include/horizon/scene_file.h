/* horizon scene files (docs/scene.md): a JSON document (jansson) naming the
 * terrain, the lights, materials, models (a built-in box, or any file
 * assimp reads: glTF/GLB, OBJ, FBX, ...) and a tree of nodes, each placed
 * in local metres, in the terrain's CRS or in lon/lat (PROJ), optionally
 * clamped to the ground, turned by yaw/pitch/roll or an axis and angle,
 * scaled, with attributes for picking. No GL.
 *
 * Two steps, because the terrain comes first: hz_scene_file_open parses and
 * checks the whole document (and reads the terrain and lights); the CLI
 * loads the terrain; hz_scene_file_build then adds the nodes to a scene on
 * that terrain. Every error names the file, the JSON path and the reason:
 * "city.scene.json: nodes[3].children[0].scale: must be > 0 (got -1)". */
#ifndef HORIZON_SCENE_FILE_H
#define HORIZON_SCENE_FILE_H

#include "horizon/city.h"
#include "horizon/georef.h"
#include "horizon/scene.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct hz_scene_file hz_scene_file; /* opaque CPU object */

typedef struct hz_scene_file_info {
    /* "terrain": a DEM path (resolved against the scene file's folder) or a
     * generated terrain; none when the file has no "terrain". */
    bool has_terrain;
    char dem[1024];
    char generate[16];     /* "perlin" / "diamond" when generated */
    uint32_t size;         /* generated: 2^n+1 */
    uint64_t seed;
    float amplitude;       /* 0 = the generator's default */
    float spacing;         /* 0 = the DEM's own */
    /* "lights" */
    bool has_sun;
    float sun[2];          /* azimuth (clockwise from north), elevation, degrees */
    uint32_t nodes, models, materials;
} hz_scene_file_info;

/* Parses and checks a scene file (size limit: 256 MiB). NULL + err on any
 * problem: unreadable file, JSON syntax (with line and column), unknown
 * members, bad numbers (NaN, out of range), unknown model or material
 * names, a model file assimp cannot read, a CRS/lon-lat position that
 * needs a georeferenced terrain is checked at build time. */
hz_scene_file *hz_scene_file_open(const char *path, hz_scene_file_info *info, hz_err *err);
/* The same from memory; dir resolves relative model/DEM paths (NULL: "."). */
hz_scene_file *hz_scene_file_open_memory(const char *data, size_t size, const char *name, const char *dir,
                                         hz_scene_file_info *info, hz_err *err);
void hz_scene_file_destroy(hz_scene_file *f);

typedef struct hz_scene_file_place {
    const hz_georef *georef;   /* the terrain's; NULL: "crs" and "lonlat" positions are refused */
    hz_ground_fn ground;       /* for "clamp": "ground"; NULL: clamping is refused */
    void *ground_user;
} hz_scene_file_place;

typedef struct hz_scene_file_stats {
    uint32_t nodes, objects, clamped;
    uint32_t meshes;           /* meshes added (one per model used) */
    double ms;
} hz_scene_file_stats;

/* Adds the file's materials, models and nodes to s (hz_scene_update is
 * called). HZ_ERR_* + err with the JSON path on a position PROJ cannot
 * convert, a CRS position without a georeference, ground clamping without
 * ground. stats may be NULL. */
hz_result hz_scene_file_build(hz_scene_file *f, hz_scene *s, const hz_scene_file_place *p, hz_scene_file_stats *stats,
                              hz_err *err);

#ifdef __cplusplus
}
#endif
#endif
