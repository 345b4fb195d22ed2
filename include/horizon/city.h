/* horizon city models: CityJSON 2.0 (cityjson.org) read with jansson,
 * faces triangulated, and placed into a scene graph on a terrain through
 * its georeference (PROJ). No GL.
 *
 * What is read: every CityObject's geometry of the highest LoD (or the one
 * asked for): Solid, MultiSolid, CompositeSolid, MultiSurface,
 * CompositeSurface, and GeometryInstance (a geometry template's real
 * vertices transformed by its row-major transformationMatrix and moved to
 * its reference point, which here become vertices of the city like the
 * rest); vertices dequantised with `transform` (required, as in
 * CityJSON 2.0); the CRS from metadata.referenceSystem (an OGC CRS URL or
 * URN or "EPSG:n"), checked by PROJ; semantic surfaces (RoofSurface,
 * WallSurface, GroundSurface...) when present, else each triangle is a
 * roof, wall or ground by its normal; appearance materials (their diffuse
 * colour, per surface, of the file's default-theme-material or else each
 * geometry's first theme). TINRelief objects are the terrain. Textures are
 * not read. A CityJSON Text Sequence (CityJSONL: a CityJSON header line,
 * then one CityJSONFeature per line with its own vertices, quantised by the
 * header's transform) is read as one city. */
#ifndef HORIZON_CITY_H
#define HORIZON_CITY_H

#include "horizon/core.h"
#include "horizon/georef.h"
#include "horizon/scene.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef enum hz_surface_kind {
    HZ_SURF_WALL = 0,
    HZ_SURF_ROOF = 1,
    HZ_SURF_GROUND = 2,
    HZ_SURF_KINDS = 3
} hz_surface_kind;

typedef struct hz_city_object {
    char *id;            /* the CityObject's key */
    char *type;          /* "Building", "TINRelief", ... */
    char *attributes;    /* its "attributes" as compact JSON text ("{}" when none) */
    float lod;           /* of the geometry read */
    bool terrain;        /* TINRelief */
    uint32_t first_tri, tri_count; /* into hz_city.tris */
    uint32_t faces;      /* polygons read (before triangulation) */
} hz_city_object;

/* An appearance material (CityJSON appearance.materials): its diffuse colour
 * ([0.8, 0.8, 0.8] when the file gives none) and name. */
typedef struct hz_city_material {
    float color[3];
    char name[32];
} hz_city_material;

#define HZ_CITY_NO_MATERIAL 0xffffffffu
/* The largest |coordinate| of a city vertex, in its CRS's units (25 times
 * the Earth's circumference in metres): CityJSON vertices once dequantised
 * (and instances once transformed) and footprint vertices once in the
 * terrain's CRS beyond it are refused, as only a broken file puts them
 * there. */
#define HZ_CITY_MAX_COORD 1e9

typedef struct hz_city {
    double *verts;        /* x, y, z per vertex: CRS easting, northing, height (dequantised) */
    uint32_t vert_count;
    uint32_t *tris;       /* 3 vertex indices per triangle */
    uint8_t *tri_kind;    /* hz_surface_kind per triangle */
    uint32_t *tri_material; /* per triangle an index into materials, or HZ_CITY_NO_MATERIAL */
    hz_city_material *materials; /* appearance.materials (material_count) */
    uint32_t material_count;
    char material_theme[64]; /* the theme read: default-theme-material, else each geometry's first */
    uint32_t tri_count;
    hz_city_object *obj;
    uint32_t obj_count;
    uint32_t buildings;   /* objects of type Building / BuildingPart with triangles */
    uint32_t terrain_objects;
    uint64_t faces;
    bool semantics;       /* some surface kinds came from semantics */
    uint32_t instances;   /* GeometryInstances read (their template's vertices are appended to verts) */
    uint32_t features;    /* CityJSONFeatures read (a CityJSON Text Sequence, .city.jsonl); 0 for a file */
    /* Footprints: how many buildings took their height from a height field,
     * from a levels field, or the default; the fields' names (the first
     * layer's that has them, "" when none had). */
    uint32_t height_from_field, height_from_levels, height_default;
    char height_field[32], levels_field[32];
    char crs[64];         /* "EPSG:32734", "" when the file has none */
    char version[16];
    double extent[6];     /* min x, y, z, max x, y, z of the vertices used */
    double load_ms;
    char note[200];       /* a repair made while reading (empty: none) */
} hz_city;

typedef struct hz_city_desc {
    float lod;            /* geometry LoD to read; 0 -> the highest each object has */
    uint64_t max_bytes;   /* refuse files larger; 0 -> 1 GiB */
} hz_city_desc;

/* Reads a CityJSON file. NULL + err (with the file name and the JSON path
 * of the problem: "CityObjects.b1.geometry[0].boundaries[0][2]: vertex 99
 * out of range (12 vertices)") on: unreadable file, bad JSON, not CityJSON,
 * a missing or bad `transform`, vertex indices out of range, an unknown
 * CRS. desc may be NULL. */
hz_city *hz_city_load(const char *path, const hz_city_desc *desc, hz_err *err);
/* The same from memory (name is used in messages). */
hz_city *hz_city_load_memory(const char *data, size_t size, const char *name, const hz_city_desc *desc, hz_err *err);
void hz_city_destroy(hz_city *c);

/* Vector footprints through GDAL's OGR (GeoJSON, GeoPackage, Shapefile, OSM
 * PBF ... every layer with polygons) extruded to closed LoD1 solids: walls
 * (one quad per ring edge, outward), a flat roof and a floor. Height per
 * feature: the number in height_field, else levels_field times
 * level_height, else default_height. Without a name given, the first field
 * a layer has of "height", "building:height", "measuredHeight" (heights),
 * and of "building:levels", "num_floors" (Overture), "building_l" (a
 * Shapefile's cut of building:levels), "levels" (levels); names match
 * whatever their case. Every field becomes an attribute;
 * the object id is the field "osm_id" or "id" when present, else the
 * layer name and feature id. Geographic CRSs (lon/lat, e.g. GeoJSON's
 * default) are projected to the WGS 84 UTM zone of the data's centre. The
 * solids' bases are at height 0: place them with a ground function.
 * NULL + err on an unreadable file, no polygon, a CRS PROJ does not know. */
typedef struct hz_footprint_desc {
    const char *height_field;   /* NULL -> the first of "height", "building:height", "measuredHeight" */
    const char *levels_field;   /* NULL -> the first of "building:levels", "num_floors", "building_l", "levels" */
    float level_height;         /* metres per level; 0 -> 3 */
    float default_height;       /* 0 -> 10 */
} hz_footprint_desc;
hz_city *hz_city_load_footprints(const char *path, const hz_footprint_desc *desc, hz_err *err);

/* Triangulates one planar polygon (outer ring then holes, vertices in 3D,
 * no ring closes itself by repeating its first vertex): ear clipping on the
 * plane of its Newell normal, holes bridged to the outer ring. ring_start
 * [ring_count + 1] gives each ring's first vertex in pts (x, y, z triples,
 * doubles) and the end. Writes up to (n - 2 + 2 * holes) * 3 indices into
 * pts to tris (n = all vertices) and returns the triangle count, 0 for a
 * degenerate polygon; -1 on out of memory. */
int hz_polygon_triangulate(const double *pts, const uint32_t *ring_start, uint32_t ring_count, uint32_t *tris);

/* Ground height (world metres) at world (x, z): what clamping puts buildings on. */
typedef float (*hz_ground_fn)(void *user, float x, float z);

typedef struct hz_city_place {
    const hz_georef *georef; /* the terrain's; NULL: local = CRS - origin (below) */
    double origin[2];        /* without georef: CRS point that becomes local (0, 0) */
    hz_ground_fn ground;     /* optional: each building is moved vertically so its lowest
                                vertex sits on the lowest ground under its footprint */
    void *ground_user;
    uint32_t tiles;          /* buildings grouped into tiles x tiles group nodes (culling
                                hierarchy); 0 -> 16 */
    float float_tolerance;   /* reported only */
} hz_city_place;

typedef struct hz_city_placed {
    uint32_t buildings;      /* building nodes added */
    uint32_t nodes;          /* all nodes added */
    uint64_t triangles;      /* mesh triangles added */
    double max_shift;        /* largest clamping move, metres */
    double mean_shift;       /* over the clamped buildings */
    uint32_t clamped;        /* buildings moved onto the ground */
    uint32_t outside;        /* buildings with no ground under them (ground gave NaN
                                everywhere): left at their own heights */
    uint32_t materials[HZ_SURF_KINDS]; /* scene material of walls, roofs, ground */
    uint32_t first_material; /* scene material of the city's appearance material 0 (the others follow) */
} hz_city_placed;

/* Adds the city's non-terrain objects to a scene (after hz_scene_update
 * their world boxes are in the terrain's local metres): a group node
 * "city", tiles under it, one node per object (named by its id, with its
 * attributes) drawn with the wall material, and children for its roof and
 * ground surfaces. Vertices are converted from the city's CRS to the
 * georeference's CRS through PROJ when they differ. Fails when the city
 * has no CRS and georef is given, or PROJ cannot convert. */
hz_result hz_city_to_scene(const hz_city *c, hz_scene *s, const hz_city_place *p, hz_city_placed *out, hz_err *err);

/* Rasterises the TINRelief triangles into a north-up grid of cell metres
 * (samples at cell centres; NaN where no triangle covers): *heights
 * (allocated, w * h, row 0 north), gt the GDAL geotransform in the city's
 * CRS. HZ_ERR_VALUE when the city has no terrain. */
hz_result hz_city_tin_grid(const hz_city *c, double cell, float **heights, uint32_t *w, uint32_t *h, double gt[6],
                           hz_err *err);

#ifdef __cplusplus
}
#endif
#endif
