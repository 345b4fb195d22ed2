/* Effect names, the --effects list syntax and the settings defaults. */
#include "horizon/fx.h"

#include <ctype.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

static const char *const names[HZ_FX_COUNT] = {"sky",  "flare", "shadows", "detail",     "billboards",
                                               "fog",  "water", "weather", "motionblur", "bloom"};

const char *hz_fx_name(uint32_t k)
{
    return k < HZ_FX_COUNT ? names[k] : NULL;
}

hz_result hz_fx_parse(const char *list, uint32_t *bits, hz_err *err)
{
    uint32_t b = 0;
    if (!list || !bits)
        return hz_err_set(err, HZ_ERR_VALUE, "effects: no list");
    const char *p = list;
    bool any = false;
    while (*p) {
        const char *e = strchr(p, ',');
        size_t len = e ? (size_t)(e - p) : strlen(p);
        /* Trim spaces. */
        while (len && isspace((unsigned char)*p))
            p++, len--;
        while (len && isspace((unsigned char)p[len - 1]))
            len--;
        bool remove = len && *p == '-';
        const char *w = remove ? p + 1 : p;
        size_t wl = remove ? len - 1 : len;
        char tok[32];
        if (wl == 0 || wl >= sizeof tok)
            goto bad;
        memcpy(tok, w, wl);
        tok[wl] = 0;
        uint32_t set = 0;
        bool whole = false;
        if (!strcmp(tok, "all"))
            set = HZ_FX_ALL, whole = true;
        else if (!strcmp(tok, "none"))
            set = 0, whole = true;
        else if (!strcmp(tok, "default"))
            set = HZ_FX_DEFAULT, whole = true;
        else {
            uint32_t k = 0;
            while (k < HZ_FX_COUNT && strcmp(tok, names[k]))
                k++;
            if (k == HZ_FX_COUNT)
                goto bad;
            set = 1u << k;
        }
        if (whole && remove)
            goto bad;
        if (whole)
            b = set;
        else if (remove)
            b &= ~set;
        else
            b |= set;
        any = true;
        if (!e)
            break;
        p = e + 1;
        continue;
    bad:
        return hz_err_set(err, HZ_ERR_VALUE,
                          "effects: unknown effect '%.*s' in '%s' (use all, none, default or a comma-separated "
                          "list of sky, flare, shadows, detail, billboards, fog, water, weather, motionblur, "
                          "bloom; -name removes one)",
                          (int)(len < 40 ? len : 40), p, list);
    }
    if (!any)
        return hz_err_set(err, HZ_ERR_VALUE, "effects: empty list (use none for no effects)");
    *bits = b;
    return HZ_OK;
}

size_t hz_fx_format(uint32_t bits, char *buf, size_t cap)
{
    size_t n = 0;
    if (cap)
        buf[0] = 0;
    for (uint32_t k = 0; k < HZ_FX_COUNT; k++) {
        if (!(bits & (1u << k)))
            continue;
        int w = snprintf(cap > n ? buf + n : NULL, cap > n ? cap - n : 0, "%s%s", n ? "," : "", names[k]);
        n += (size_t)w;
    }
    if (n == 0) {
        if (cap)
            snprintf(buf, cap, "none");
        n = 4;
    }
    return n;
}

hz_fx_settings hz_fx_settings_defaults(const hz_fx_settings *in, float fog_density)
{
    hz_fx_settings s = in ? *in : (hz_fx_settings){0};
    if (s.cloud_cover == 0.0f)
        s.cloud_cover = 0.45f;
    else if (s.cloud_cover < 0.0f)
        s.cloud_cover = 0.0f;
    s.cloud_cover = s.cloud_cover > 1.0f ? 1.0f : s.cloud_cover;
    if (s.cloud_altitude == 0.0f)
        s.cloud_altitude = 2500.0f;
    if (s.wind[0] == 0.0f && s.wind[1] == 0.0f) {
        s.wind[0] = 6.0f;
        s.wind[1] = -3.0f;
    }
    if (s.flare == 0.0f)
        s.flare = 1.0f;
    if (s.height_fog == 0.0f)
        s.height_fog = 3.0f * (fog_density > 0.0f ? fog_density : 0.0f);
    else if (s.height_fog < 0.0f)
        s.height_fog = 0.0f;
    if (s.height_fog_falloff <= 0.0f)
        s.height_fog_falloff = 200.0f;
    if (s.weather_intensity <= 0.0f)
        s.weather_intensity = 1.0f;
    if (s.blur == 0.0f)
        s.blur = 0.5f;
    s.blur = s.blur < 0.0f ? 0.0f : s.blur > 0.98f ? 0.98f : s.blur;
    if (s.exposure <= 0.0f)
        s.exposure = 1.0f;
    if (s.gamma <= 0.0f)
        s.gamma = 1.0f;
    if (s.bloom_threshold <= 0.0f)
        s.bloom_threshold = 0.8f;
    if (s.bloom_strength <= 0.0f)
        s.bloom_strength = 0.35f;
    if (s.detail_scale <= 0.0f)
        s.detail_scale = 3.0f;
    if (s.billboard_distance <= 0.0f)
        s.billboard_distance = 4000.0f;
    return s;
}
