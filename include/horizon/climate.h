/* horizon climate: where a place is on Earth decides what its ground looks
 * like. Snow line and tree line in metres above sea level (absolute, not
 * relative to the map) from the latitude, and how arid it is (desert: no
 * vegetation, no forest, no lakes) from a coarse table of the world's dry
 * regions. No GL: the renderer shades by it (hz_renderer_set_climate), the
 * commands place trees and water by it.
 *
 * NOTE: a deliberately coarse model — a latitude profile of the climatic snow
 * and tree lines and rectangles around the large deserts and steppes — good
 * enough for a first image that looks like the place, not a climate atlas. */
#ifndef HORIZON_CLIMATE_H
#define HORIZON_CLIMATE_H

#include <stdbool.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef enum hz_climate_kind {
    HZ_CLIMATE_AUTO = 0,  /* from the place (hz_climate_at), else temperate */
    HZ_CLIMATE_TEMPERATE, /* green lowlands, forests below the tree line */
    HZ_CLIMATE_ARID,      /* desert: sand and bare rock, no vegetation, no lakes */
    HZ_CLIMATE_STEPPE,    /* semi-arid: dry grass, no forests, no lakes */
    HZ_CLIMATE_TROPICAL,  /* high snow and tree lines */
    HZ_CLIMATE_POLAR      /* low snow line, no trees */
} hz_climate_kind;

typedef struct hz_climate {
    hz_climate_kind kind;
    float latitude;   /* degrees the lines were taken at */
    float snow_line;  /* metres above sea level: permanent snow above (on gentle slopes) */
    float tree_line;  /* metres above sea level: no trees above; alpine grass up to ~tree_line + 600 */
    float aridity;    /* 0 (wet: green) .. 1 (desert: no vegetation) */
} hz_climate;

/* Snow and tree line (metres) of a latitude (degrees; |lat| used). */
void hz_climate_lines(double lat, float *snow_line, float *tree_line);
/* The climate at lon/lat (degrees, WGS 84): lines from the latitude, aridity
 * and kind from the table of dry regions (arid lines: snow 500 m higher). */
hz_climate hz_climate_at(double lon, double lat);
/* A climate of the given kind at a latitude (the plausible default for a
 * DEM without a georeference: temperate at 45 degrees). AUTO -> temperate. */
hz_climate hz_climate_of_kind(hz_climate_kind kind, double lat);
/* Names: "auto", "temperate", "arid", "steppe", "tropical", "polar". */
const char *hz_climate_name(hz_climate_kind kind);
bool hz_climate_parse(const char *s, hz_climate_kind *out);

#ifdef __cplusplus
}
#endif
#endif
