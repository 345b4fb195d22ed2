/* horizon view's config file and input script (see view_input.h). */
#define _POSIX_C_SOURCE 200809L
#include "view_input.h"

#include <ini.h>

#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "cli.h"
#include "horizon/window.h"

const char *view_printable(const char *s, char *buf, size_t cap)
{
    size_t n = 0;
    for (; *s && n + 8 < cap && n < 80; s++) {
        unsigned char c = (unsigned char)*s;
        if (c >= 0x20 && c < 0x7f)
            buf[n++] = (char)c;
        else
            n += (size_t)snprintf(buf + n, cap - n, "\\x%02x", c);
    }
    if (*s && n + 4 < cap) {
        memcpy(buf + n, "...", 3);
        n += 3;
    }
    buf[n < cap ? n : cap - 1] = 0;
    return buf;
}

/* Opens a text input, refusing what is not a regular file (a folder would
 * read as empty). NULL after the message. */
static FILE *open_text(const char *file, const char *what)
{
    FILE *f = fopen(file, "r");
    if (!f) {
        fprintf(stderr, "horizon view: cannot open %s %s: %s\n", what, file, strerror(errno));
        return NULL;
    }
    struct stat st;
    if (fstat(fileno(f), &st) != 0 || S_ISDIR(st.st_mode)) {
        fprintf(stderr, "horizon view: cannot read %s %s: it is a directory, not a file\n", what, file);
        fclose(f);
        return NULL;
    }
    return f;
}

/* The next line into line (without its end). 0 for a line, -1 at the end of
 * the file, 2 after a message: read error, over-long line, binary data. */
static int next_line(FILE *f, const char *file, const char *what, char *line, size_t cap, int *lineno)
{
    size_t n = 0;
    int c;
    while ((c = getc(f)) != EOF && c != '\n') {
        if (n + 1 >= cap) {
            fprintf(stderr, "horizon view: %s:%d: line too long (over %zu bytes)\n", file, *lineno + 1, cap - 1);
            return 2;
        }
        if ((c < 0x20 && c != '\t' && c != '\r') || c == 0x7f) {
            fprintf(stderr, "horizon view: %s:%d: byte 0x%02x at column %zu: binary data, not a text %s file\n",
                    file, *lineno + 1, (unsigned)c, n + 1, what);
            return 2;
        }
        line[n++] = (char)c;
    }
    if (ferror(f)) {
        fprintf(stderr, "horizon view: cannot read %s %s: %s\n", what, file, strerror(errno));
        return 2;
    }
    if (c == EOF && n == 0)
        return -1;
    line[n] = 0;
    (*lineno)++;
    return 0;
}

/* Options that take no value: those of the shared parser and ours. */
static const char *const flag_opts[] = {"no-cull", "json",     "wireframe",     "quiet",      "walk",
                                        "free",    "fans",     "boxes",         "no-hud", "hud-full",     "no-vsync",
                                        "no-simplify", "no-hysteresis", "no-enlarge", "no-node-cull"};

bool view_is_flag(const char *name)
{
    for (size_t k = 0; k < sizeof flag_opts / sizeof flag_opts[0]; k++)
        if (!strcmp(name, flag_opts[k]))
            return true;
    return false;
}


static bool strlist_add(strlist *l, const char *s)
{
    if (l->count == l->cap) {
        size_t cap = l->cap ? 2 * l->cap : 16;
        char **p = realloc(l->s, cap * sizeof *p);
        if (!p)
            return false;
        l->s = p;
        l->cap = cap;
    }
    char *d = strdup(s);
    if (!d)
        return false;
    l->s[l->count++] = d;
    return true;
}

void strlist_free(strlist *l)
{
    for (size_t k = 0; k < l->count; k++)
        free(l->s[k]);
    free(l->s);
    *l = (strlist){0};
}

static char *trim(char *s)
{
    while (isspace((unsigned char)*s))
        s++;
    size_t n = strlen(s);
    while (n && isspace((unsigned char)s[n - 1]))
        s[--n] = 0;
    return s;
}

/* Reads `key = value` lines into "--key value" tokens. skip_source: the
 * command line names the terrain itself, so --dem/--generate here are dropped
 * (cli_parse refuses both at once). Returns 0 or 2 (message printed). */
/* libinih reads the config; a line reader in front of it keeps the checks it
 * lacks (binary data, over-long lines) and counts lines, so that every error
 * names the file and the line. */
typedef struct cfg_ctx {
    FILE *f;
    const char *file;
    int lineno;
    int rc;           /* 0, 1 out of memory, 2 after a message */
    strlist *out;
    bool skip_source;
    char last[1024];  /* the line read last (inih stops at the first error: the bad one) */
} cfg_ctx;

static char *cfg_reader(char *str, int num, void *stream)
{
    cfg_ctx *c = stream;
    char line[1024];
    if (c->rc || num < 2)
        return NULL;
    int r = next_line(c->f, c->file, "config", line, sizeof line, &c->lineno);
    if (r == 2)
        c->rc = 2;
    if (r)
        return NULL;
    snprintf(c->last, sizeof c->last, "%s", line);
    snprintf(str, (size_t)num, "%s\n", line);
    return str;
}

static int cfg_handler(void *user, const char *section, const char *name, const char *value)
{
    cfg_ctx *c = user;
    char q[256], key_buf[256], val_buf[1024];
    if (c->rc)
        return 0;
    if (section && section[0]) {
        fprintf(stderr, "horizon view: %s:%d: sections ([%s]) are not used: one 'key = value' per line\n", c->file,
                c->lineno, view_printable(section, q, sizeof q));
        c->rc = 2;
        return 0;
    }
    snprintf(key_buf, sizeof key_buf, "%s", name);
    snprintf(val_buf, sizeof val_buf, "%s", value ? value : "");
    char *key = trim(key_buf), *val = trim(val_buf);
    /* A trailing comment after whitespace ('#'; inih strips ';'). */
    for (char *h = val; *h; h++)
        if (*h == '#' && h > val && isspace((unsigned char)h[-1])) {
            *h = 0;
            val = trim(val);
            break;
        }
    size_t vl = strlen(val);
    if (vl >= 2 && ((val[0] == '"' && val[vl - 1] == '"') || (val[0] == '\'' && val[vl - 1] == '\''))) {
        val[vl - 1] = 0;
        val++;
    }
    while (*key == '-')
        key++;
    if (!*key) {
        fprintf(stderr, "horizon view: %s:%d: empty key\n", c->file, c->lineno);
        c->rc = 2;
        return 0;
    }
    if (!strcmp(key, "config")) {
        fprintf(stderr, "horizon view: %s:%d: config files do not nest\n", c->file, c->lineno);
        c->rc = 2;
        return 0;
    }
    if (c->skip_source && (!strcmp(key, "dem") || !strcmp(key, "generate")))
        return 1;
    char opt[300];
    snprintf(opt, sizeof opt, "--%s", key);
    if (view_is_flag(key)) {
        if (!strcmp(val, "true") || !strcmp(val, "yes") || !strcmp(val, "on") || !strcmp(val, "1")) {
            if (!strlist_add(c->out, opt))
                c->rc = 1;
        } else if (strcmp(val, "false") && strcmp(val, "no") && strcmp(val, "off") && strcmp(val, "0")) {
            fprintf(stderr, "horizon view: %s:%d: '%s' takes true or false, got '%s'\n", c->file, c->lineno,
                    view_printable(key, q, sizeof q), val);
            c->rc = 2;
        }
        return c->rc == 0;
    }
    if (!*val) {
        fprintf(stderr, "horizon view: %s:%d: '%s' needs a value\n", c->file, c->lineno,
                view_printable(key, q, sizeof q));
        c->rc = 2;
        return 0;
    }
    if (!strlist_add(c->out, opt) || !strlist_add(c->out, val))
        c->rc = 1;
    return c->rc == 0;
}

int view_config_read(const char *file, strlist *out, bool skip_source)
{
    FILE *f = open_text(file, "config");
    if (!f)
        return 2;
    cfg_ctx c = {.f = f, .file = file, .out = out, .skip_source = skip_source};
    /* NOTE: libinih's settings are process-wide variables (Debian builds
     * them so): one key per line (an indented line is not a continuation),
     * stop at the first error, lines as long as ours. */
    ini_allow_multiline = false;
    ini_stop_on_first_error = true;
    ini_use_stack = false;
    ini_max_line = 1100;
    const int r = ini_parse_stream(cfg_reader, &c, cfg_handler, &c);
    int rc = c.rc;
    if (!rc && r > 0) {
        /* A line inih could not read as 'key = value' (quoted, escaped). */
        char q[256];
        if (r == c.lineno)
            fprintf(stderr, "horizon view: %s:%d: expected 'key = value', got '%s'\n", file, r,
                    view_printable(trim(c.last), q, sizeof q));
        else
            fprintf(stderr, "horizon view: %s:%d: expected 'key = value'\n", file, r);
        rc = 2;
    } else if (!rc && r < 0) {
        rc = 1;
    }
    if (rc == 1)
        fprintf(stderr, "horizon view: out of memory reading %s\n", file);
    fclose(f);
    return rc;
}

void script_free(script *s)
{
    for (size_t k = 0; k < s->count; k++)
        free(s->ev[k].file);
    free(s->ev);
    *s = (script){0};
}

static script_event *script_push(script *s)
{
    if (s->count == s->cap) {
        size_t cap = s->cap ? 2 * s->cap : 64;
        script_event *p = realloc(s->ev, cap * sizeof *p);
        if (!p)
            return NULL;
        s->ev = p;
        s->cap = cap;
    }
    script_event *e = &s->ev[s->count];
    memset(e, 0, sizeof *e);
    e->seq = (uint32_t)s->count++;
    return e;
}

static int cmp_event(const void *a, const void *b)
{
    const script_event *x = a, *y = b;
    if (x->frame != y->frame)
        return x->frame < y->frame ? -1 : 1;
    return (x->seq > y->seq) - (x->seq < y->seq);
}

static int button_from_name(const char *s)
{
    if (!strcmp(s, "left")) return HZ_MOUSE_LEFT;
    if (!strcmp(s, "right")) return HZ_MOUSE_RIGHT;
    if (!strcmp(s, "middle")) return HZ_MOUSE_MIDDLE;
    return -1;
}

/* Parses floats tok[0..n) into v. */
static bool floats(char **tok, int n, float *v)
{
    for (int k = 0; k < n; k++)
        if (!tok[k] || !cli_parse_float(tok[k], -1e8, 1e8, &v[k]))
            return false;
    return true;
}

/* Reads a script: "WHEN VERB ARGS" per line, WHEN = frame number or seconds
 * with an 's' suffix (converted with dt). Returns 0 or 2 (message printed). */
int view_script_load(const char *file, float dt, script *s)
{
    FILE *f = open_text(file, "script");
    if (!f)
        return 2;
    char line[1024];
    int lineno = 0, rc = 0;
    while (!rc && (rc = next_line(f, file, "script", line, sizeof line, &lineno)) == 0) {
        char *hash = strchr(line, '#');
        if (hash)
            *hash = 0;
        char *tok[8] = {0}, *save = NULL;
        int nt = 0;
        for (char *t = strtok_r(line, " \t\r\n", &save); t && nt < 8; t = strtok_r(NULL, " \t\r\n", &save))
            tok[nt++] = t;
        if (nt == 0)
            continue;
        const char *why = NULL;
        uint32_t frame = 0;
        size_t tl = strlen(tok[0]);
        float secs;
        if (tl > 1 && tok[0][tl - 1] == 's') {
            tok[0][tl - 1] = 0;
            if (!cli_parse_float(tok[0], 0, 1e7, &secs))
                why = "bad time (a frame number, or seconds like 1.5s)";
            else if ((double)secs / (double)dt > 1e8)
                why = "time beyond frame 1e8 at this --dt";
            else
                frame = (uint32_t)lround((double)secs / (double)dt);
        } else if (!cli_parse_u32(tok[0], 0, 100000000, &frame)) {
            why = "bad frame number (a frame number, or seconds like 1.5s)";
        }
        script_event *e = why ? NULL : script_push(s);
        if (!why && !e) {
            rc = 1;
            break;
        }
        if (e)
            e->frame = frame;
        const char *verb = nt > 1 ? tok[1] : "";
        if (why) {
        } else if (!strcmp(verb, "key") || !strcmp(verb, "button")) {
            bool key = !strcmp(verb, "key");
            e->kind = key ? EV_KEY : EV_BUTTON;
            e->code = nt > 2 ? (key ? hz_key_from_name(tok[2]) : button_from_name(tok[2])) : -1;
            const char *act = nt > 3 ? tok[3] : "";
            if (e->code < 0)
                why = key ? "unknown key name (e.g. W, TAB, F3, SHIFT, ESC, UP)" : "unknown button (left, right, middle)";
            else if (nt != 4 || (strcmp(act, "down") && strcmp(act, "up") && strcmp(act, "press")))
                why = "expected: WHEN key|button NAME down|up|press";
            else if (!strcmp(act, "press")) {
                /* Down this frame, up the next. NOTE: script_push may move
                 * the array, so e is not used after it. */
                e->down = true;
                const ev_kind kind = e->kind;
                const int code = e->code;
                script_event *u = script_push(s);
                if (!u) {
                    rc = 1;
                    break;
                }
                u->kind = kind;
                u->code = code;
                u->frame = frame + 1;
                u->down = false;
            } else {
                e->down = !strcmp(act, "down");
            }
        } else if (!strcmp(verb, "mouse") || !strcmp(verb, "look")) {
            e->kind = verb[0] == 'm' ? EV_MOUSE : EV_LOOK;
            if (nt != 4 || !floats(tok + 2, 2, e->v))
                why = "expected: WHEN mouse DX DY (pixels) or WHEN look DYAW DPITCH (degrees)";
        } else if (!strcmp(verb, "scroll")) {
            e->kind = EV_SCROLL;
            if (nt != 3 || !floats(tok + 2, 1, e->v))
                why = "expected: WHEN scroll NOTCHES";
        } else if (!strcmp(verb, "resize")) {
            e->kind = EV_RESIZE;
            if (nt != 4 || !floats(tok + 2, 2, e->v) || e->v[0] < 16 || e->v[1] < 16 || e->v[0] > 8192 ||
                e->v[1] > 8192)
                why = "expected: WHEN resize W H (16..8192 pixels)";
        } else if (!strcmp(verb, "camera")) {
            e->kind = EV_CAMERA;
            if (nt != 7 || !floats(tok + 2, 5, e->v))
                why = "expected: WHEN camera X Y Z YAW PITCH";
        } else if (!strcmp(verb, "screenshot")) {
            e->kind = EV_SCREENSHOT;
            if (nt != 3 || !(e->file = strdup(tok[2])))
                why = "expected: WHEN screenshot FILE.png";
        } else if (!strcmp(verb, "quit")) {
            e->kind = EV_QUIT;
            if (nt != 2)
                why = "expected: WHEN quit";
        } else {
            why = "unknown event (key, button, mouse, look, scroll, resize, camera, screenshot, quit)";
        }
        if (why) {
            fprintf(stderr, "horizon view: %s:%d: %s\n", file, lineno, why);
            rc = 2;
        }
    }
    fclose(f);
    if (rc < 0)
        rc = 0; /* end of file */
    if (rc == 1)
        fprintf(stderr, "horizon view: out of memory reading %s\n", file);
    if (!rc && s->count)
        qsort(s->ev, s->count, sizeof *s->ev, cmp_event);
    return rc;
}

