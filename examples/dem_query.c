/* Loads a DEM and queries heights by lon/lat and by local metres.
 *   dem_query FILE [LON LAT]
 * Build against an installed libhorizon:
 *   cc dem_query.c $(pkg-config --cflags --libs horizon) -o dem_query */
#include <stdio.h>
#include <stdlib.h>

#include <horizon/terrain.h>

int main(int argc, char **argv)
{
    if (argc != 2 && argc != 4) {
        fprintf(stderr, "usage: dem_query FILE [LON LAT]\n");
        return 2;
    }
    hz_err err = {0};
    hz_terrain *t = hz_terrain_create(&(hz_terrain_desc){.dem_path = argv[1]}, &err);
    if (!t) {
        fprintf(stderr, "dem_query: %s\n", err.msg);
        return 1;
    }
    printf("terrain %s: %u x %u samples at %.2f m, heights %.1f .. %.1f m\n", t->source, t->data_w, t->data_h,
           (double)t->spacing, (double)t->min_h, (double)t->max_h);
    /* Local metres: x east, z south, from the north-west sample. */
    const float x = 0.5f * (float)(t->data_w - 1) * t->spacing, z = 0.5f * (float)(t->data_h - 1) * t->spacing;
    printf("local (%.1f, %.1f) m: height %.2f m\n", (double)x, (double)z, (double)hz_terrain_surface_at(t, x, z));
    int rc = 0;
    if (!t->georef) {
        printf("no georeference: lon/lat queries need a georeferenced DEM\n");
    } else {
        double lon, lat;
        if (argc == 4) {
            lon = atof(argv[2]);
            lat = atof(argv[3]);
        } else if (hz_georef_local_to_lonlat(t->georef, x, z, &lon, &lat, &err) != HZ_OK) {
            fprintf(stderr, "dem_query: %s\n", err.msg);
            rc = 1;
            goto out;
        }
        double lx, lz;
        if (hz_georef_lonlat_to_local(t->georef, lon, lat, &lx, &lz, &err) != HZ_OK) {
            fprintf(stderr, "dem_query: %s\n", err.msg);
            rc = 1;
            goto out;
        }
        printf("lon %.6f lat %.6f (%s): local (%.1f, %.1f) m, height %.2f m\n", lon, lat, hz_georef_label(t->georef),
               lx, lz, (double)hz_terrain_surface_at(t, (float)lx, (float)lz));
    }
out:
    hz_terrain_destroy(t);
    return rc;
}
