#include "json_out.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

json_t *jx_num(double v)
{
    if (!isfinite(v))
        return json_null();
    /* 7 significant digits: what a float holds (0.002f stays 0.002). */
    char buf[32];
    snprintf(buf, sizeof buf, "%.7g", v);
    return json_real(strtod(buf, NULL));
}

json_t *jx_dbl(double v)
{
    return isfinite(v) ? json_real(v) : json_null();
}

json_t *jx_fix(double v, int digits)
{
    if (!isfinite(v))
        return json_null();
    const double k = pow(10.0, digits);
    const double r = round(v * k) / k;
    return isfinite(r) ? json_real(r) : json_real(v);
}

json_t *jx_int(long long v)
{
    return json_integer(v);
}

json_t *jx_bool(bool v)
{
    return json_boolean(v);
}

/* Length of a valid UTF-8 sequence at s (n bytes left), 0 if invalid. */
static size_t utf8_len(const unsigned char *s, size_t n)
{
    size_t len;
    unsigned min;
    if (s[0] < 0x80)
        return 1;
    if ((s[0] & 0xe0) == 0xc0)
        len = 2, min = 0x80;
    else if ((s[0] & 0xf0) == 0xe0)
        len = 3, min = 0x800;
    else if ((s[0] & 0xf8) == 0xf0 && s[0] <= 0xf4)
        len = 4, min = 0x10000;
    else
        return 0;
    if (len > n)
        return 0;
    unsigned cp = s[0] & (0x7f >> len);
    for (size_t k = 1; k < len; k++) {
        if ((s[k] & 0xc0) != 0x80)
            return 0;
        cp = cp << 6 | (s[k] & 0x3f);
    }
    if (cp < min || cp > 0x10ffff || (cp >= 0xd800 && cp <= 0xdfff))
        return 0;
    return len;
}

json_t *jx_str(const char *s)
{
    if (!s)
        return json_null();
    json_t *j = json_string(s);
    if (j)
        return j;
    /* Not UTF-8 (a file name is bytes): each bad byte becomes U+FFFD. */
    const size_t n = strlen(s);
    char *out = malloc(3 * n + 1);
    if (!out)
        return json_null();
    size_t o = 0;
    for (size_t i = 0; i < n;) {
        size_t l = utf8_len((const unsigned char *)s + i, n - i);
        if (l) {
            memcpy(out + o, s + i, l);
            o += l;
            i += l;
        } else {
            memcpy(out + o, "\xef\xbf\xbd", 3);
            o += 3;
            i++;
        }
    }
    out[o] = 0;
    j = json_string(out);
    free(out);
    return j ? j : json_null();
}

void jx_set(json_t *obj, const char *key, json_t *v)
{
    json_object_set_new(obj, key, v ? v : json_null());
}

int jx_print(json_t *obj, FILE *f)
{
    int r = json_dumpf(obj, f, JSON_COMPACT | JSON_REAL_PRECISION(15));
    json_decref(obj);
    if (r == 0 && fputc('\n', f) == EOF)
        r = -1;
    return r;
}
