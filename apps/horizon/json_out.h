/* JSON output of the horizon commands through jansson: every value escaped
 * (file names with quotes, backslashes, newlines or bytes that are not
 * UTF-8), no key twice (an object's key is set, not appended), no NaN or
 * infinity (written as null). */
#ifndef HZ_JSON_OUT_H
#define HZ_JSON_OUT_H

#include <jansson.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>

/* A number to 7 significant digits (what a float holds: 0.002f is 0.002);
 * null when not finite (JSON has no NaN or infinity). */
json_t *jx_num(double v);
/* A double with its full precision (15 digits); null when not finite. */
json_t *jx_dbl(double v);
/* A number rounded to `digits` decimals (figures such as ms keep a readable
 * precision); null when not finite. */
json_t *jx_fix(double v, int digits);
json_t *jx_int(long long v);
json_t *jx_bool(bool v);
/* A string; bytes that are not valid UTF-8 become U+FFFD; NULL -> null. */
json_t *jx_str(const char *s);
/* Sets obj[key] = v (taking the reference; a NULL v sets null). */
void jx_set(json_t *obj, const char *key, json_t *v);
/* Writes obj compactly with a newline to f and releases it. 0, or -1 on a
 * write error. */
int jx_print(json_t *obj, FILE *f);

#endif
