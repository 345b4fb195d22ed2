/* --curvature on|off|auto (issue 15, Earth curvature): parsing, the radius a
 * terrain gets, and its JSON. */
#ifndef HZ_CURV_CLI_H
#define HZ_CURV_CLI_H

#include <jansson.h>
#include <stdbool.h>

#include "horizon/camera.h"
#include "horizon/georef.h"

typedef struct curv_opts {
    hz_curvature_mode mode; /* --curvature; 0 -> auto */
    /* Resolved for the loaded terrain (curv_cli_resolve): */
    float radius;           /* metres, 0 = flat */
    float extent;           /* the terrain's side, metres */
    bool wgs84;             /* radius: the WGS84 ellipsoid's at lat (else the mean Earth radius) */
    double lat;
} curv_opts;

/* "on", "off" or "auto"; false on anything else. */
bool curv_cli_parse(const char *v, hz_curvature_mode *mode);
/* Resolves c->radius for a terrain of side extent metres: off, auto below
 * HZ_CURVATURE_AUTO_EXTENT -> 0; else the Gaussian radius of the WGS84
 * ellipsoid at the latitude of local point (cx, cz) when g is a georeference
 * (NULL: none), else the mean Earth radius. */
void curv_cli_resolve(curv_opts *c, float extent, const hz_georef *g, double cx, double cz);
/* obj["curvature"] = on?, obj["earth_radius_m"] = the radius (null when off),
 * obj["earth_radius_source"], obj["curvature_edge_drop_m"]: the drop half the
 * terrain's longer side from the eye (from its centre to the farther edges). */
void curv_cli_json(json_t *obj, const curv_opts *c);
/* One line for text output ("curvature: on, R = ... m (...)"). */
void curv_cli_print(const curv_opts *c);

#endif
