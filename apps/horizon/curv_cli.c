/* --curvature: see curv_cli.h. */
#include "curv_cli.h"

#include <stdio.h>
#include <string.h>

#include "json_out.h"

bool curv_cli_parse(const char *v, hz_curvature_mode *mode)
{
    if (!strcmp(v, "auto"))
        *mode = HZ_CURVATURE_AUTO;
    else if (!strcmp(v, "on"))
        *mode = HZ_CURVATURE_ON;
    else if (!strcmp(v, "off"))
        *mode = HZ_CURVATURE_OFF;
    else
        return false;
    return true;
}

void curv_cli_resolve(curv_opts *c, float extent, const hz_georef *g, double cx, double cz)
{
    double lon, lat;
    c->extent = extent;
    c->wgs84 = g && hz_georef_local_to_lonlat(g, cx, cz, &lon, &lat, NULL) == HZ_OK;
    c->lat = c->wgs84 ? lat : 0.0;
    c->radius = hz_curvature_radius(c->mode, extent, c->wgs84 ? (float)hz_wgs84_radius(lat) : 0.0f);
}

void curv_cli_json(json_t *obj, const curv_opts *c)
{
    const bool on = c->radius > 0.0f;
    jx_set(obj, "curvature", jx_bool(on));
    jx_set(obj, "earth_radius_m", on ? jx_fix(c->radius, 1) : NULL);
    jx_set(obj, "earth_radius_source", on ? jx_str(c->wgs84 ? "wgs84" : "mean") : NULL);
    jx_set(obj, "curvature_edge_drop_m",
           on ? jx_fix(hz_curvature_drop(c->radius, 0.5f * c->extent, 0.0f), 1) : jx_num(0.0));
}

void curv_cli_print(const curv_opts *c)
{
    if (c->radius > 0.0f)
        printf("curvature: on, R = %.0f m (%s), drop %.0f m at %.0f km\n", (double)c->radius,
               c->wgs84 ? "WGS84 at the centre's latitude" : "mean Earth radius",
               (double)hz_curvature_drop(c->radius, 0.5f * c->extent, 0.0f), 0.5 * (double)c->extent / 1000.0);
    else
        printf("curvature: off\n");
}
