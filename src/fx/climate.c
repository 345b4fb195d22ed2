/* Snow and tree lines by latitude, aridity from a table of dry regions. */
#include "horizon/climate.h"

#include <math.h>
#include <string.h>

/* Climatic snow line and tree line (metres) every 10 degrees of latitude,
 * 0..90: highest in the dry subtropics (Andes at 25-30 S, Tibet), about
 * 3000 / 2100 m at 45 degrees (Alps), sea level in the high Arctic. */
static const float SNOW[10] = {4800, 4900, 5300, 5100, 3800, 2500, 1500, 700, 200, 0};
static const float TREE[10] = {3800, 3900, 3900, 3600, 2500, 1700, 900, 300, 0, 0};

void hz_climate_lines(double lat, float *snow_line, float *tree_line)
{
    double a = fabs(lat);
    a = a > 90.0 ? 90.0 : a;
    int k = (int)(a / 10.0);
    k = k > 8 ? 8 : k;
    const float u = (float)(a / 10.0 - k);
    *snow_line = SNOW[k] + u * (SNOW[k + 1] - SNOW[k]);
    *tree_line = TREE[k] + u * (TREE[k + 1] - TREE[k]);
}

typedef struct dry_region {
    float lon0, lon1, lat0, lat1;
    float aridity;
} dry_region;

/* The large deserts (aridity 1) and steppes (0.7), as lon/lat rectangles. */
static const dry_region DRY[] = {
    {-17.5f, 33.0f, 15.0f, 31.5f, 1.0f},    /* Sahara */
    {33.0f, 60.0f, 13.0f, 31.0f, 1.0f},     /* Arabian */
    {-17.5f, 38.0f, 12.0f, 15.0f, 0.7f},    /* Sahel */
    {44.0f, 68.0f, 25.0f, 38.0f, 0.8f},     /* Iranian plateau, Afghan deserts */
    {68.0f, 76.0f, 23.0f, 30.0f, 0.8f},     /* Thar */
    {52.0f, 75.0f, 38.0f, 46.0f, 0.8f},     /* Karakum, Kyzylkum */
    {75.0f, 112.0f, 36.0f, 46.0f, 0.85f},   /* Taklamakan, Gobi */
    {40.0f, 51.5f, 1.0f, 12.0f, 0.8f},      /* Horn of Africa */
    {11.0f, 16.0f, -29.0f, -17.0f, 1.0f},   /* Namib */
    {16.0f, 26.0f, -28.0f, -19.0f, 0.7f},   /* Kalahari */
    {114.0f, 145.0f, -32.0f, -19.0f, 0.9f}, /* Australian interior */
    {-71.5f, -68.0f, -30.0f, -17.0f, 1.0f}, /* Atacama */
    {-70.0f, -63.0f, -52.0f, -38.0f, 0.7f}, /* Patagonian steppe */
    {-118.3f, -103.0f, 26.0f, 42.0f, 0.75f}, /* Great Basin, Mojave, Sonoran, Chihuahuan */
};

hz_climate hz_climate_of_kind(hz_climate_kind kind, double lat)
{
    hz_climate c = {.kind = kind ? kind : HZ_CLIMATE_TEMPERATE, .latitude = (float)lat};
    hz_climate_lines(lat, &c.snow_line, &c.tree_line);
    switch (c.kind) {
    case HZ_CLIMATE_ARID:
        c.aridity = 1.0f;
        c.snow_line += 500.0f; /* dry air: little snow */
        break;
    case HZ_CLIMATE_STEPPE:
        c.aridity = 0.7f;
        c.snow_line += 300.0f;
        break;
    case HZ_CLIMATE_TROPICAL:
        if (fabs(lat) > 23.5) {
            hz_climate_lines(15.0, &c.snow_line, &c.tree_line);
            c.latitude = lat < 0 ? -15.0f : 15.0f;
        }
        break;
    case HZ_CLIMATE_POLAR:
        if (fabs(lat) < 66.5) {
            hz_climate_lines(72.0, &c.snow_line, &c.tree_line);
            c.latitude = lat < 0 ? -72.0f : 72.0f;
        }
        break;
    default:
        break;
    }
    return c;
}

hz_climate hz_climate_at(double lon, double lat)
{
    float aridity = 0.0f;
    for (size_t k = 0; k < sizeof DRY / sizeof *DRY; k++) {
        const dry_region *r = &DRY[k];
        if (lon >= r->lon0 && lon <= r->lon1 && lat >= r->lat0 && lat <= r->lat1 && r->aridity > aridity)
            aridity = r->aridity;
    }
    hz_climate_kind kind = aridity >= 0.9f   ? HZ_CLIMATE_ARID
                           : aridity > 0.0f  ? HZ_CLIMATE_STEPPE
                           : fabs(lat) < 23.5 ? HZ_CLIMATE_TROPICAL
                           : fabs(lat) > 66.5 ? HZ_CLIMATE_POLAR
                                              : HZ_CLIMATE_TEMPERATE;
    hz_climate c = hz_climate_of_kind(kind, lat);
    if (aridity > 0.0f)
        c.aridity = aridity;
    return c;
}

static const char *const NAMES[] = {"auto", "temperate", "arid", "steppe", "tropical", "polar"};

const char *hz_climate_name(hz_climate_kind kind)
{
    return (unsigned)kind < sizeof NAMES / sizeof *NAMES ? NAMES[kind] : "?";
}

bool hz_climate_parse(const char *s, hz_climate_kind *out)
{
    for (unsigned k = 0; k < sizeof NAMES / sizeof *NAMES; k++)
        if (!strcmp(s, NAMES[k])) {
            *out = (hz_climate_kind)k;
            return true;
        }
    return false;
}
