/* horizon view's text inputs: the `key = value` config file and the timed
 * input script. Apart from cmd_view.c so the fuzzers can call them. */
#ifndef HZ_VIEW_INPUT_H
#define HZ_VIEW_INPUT_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

/* Growable list of strings we own (config tokens). */
typedef struct strlist {
    char **s;
    size_t count, cap;
} strlist;

void strlist_free(strlist *l);

/* True for the view options that take no value. */
bool view_is_flag(const char *name);

/* Reads `key = value` lines of file into "--key value" tokens appended to
 * out. skip_source: the command line names the terrain itself, so
 * --dem/--generate here are dropped (cli_parse refuses both at once).
 * Refuses folders, binary data and over-long lines. Returns 0, 1 (out of
 * memory) or 2 (bad file); the message is printed (user text escaped). */
int view_config_read(const char *file, strlist *out, bool skip_source);

typedef enum ev_kind {
    EV_KEY,        /* key down/up */
    EV_BUTTON,     /* mouse button down/up */
    EV_MOUSE,      /* mouse motion, pixels */
    EV_LOOK,       /* yaw/pitch delta, degrees */
    EV_SCROLL,
    EV_RESIZE,
    EV_CAMERA,     /* x y z yaw pitch */
    EV_SCREENSHOT,
    EV_QUIT
} ev_kind;

typedef struct script_event {
    uint32_t frame;
    uint32_t seq;  /* file order, for a stable sort */
    ev_kind kind;
    int code;      /* key or button */
    bool down;
    float v[5];
    char *file;    /* screenshot (owned) */
} script_event;

typedef struct script {
    script_event *ev;
    size_t count, cap, next;
} script;

/* Reads a script: "WHEN VERB ARGS" per line, WHEN = frame number or seconds
 * with an 's' suffix (converted with dt > 0), events sorted by frame (file
 * order within a frame). Returns 0, 1 (out of memory) or 2 (bad file;
 * message printed). s is filled even on failure: free it with script_free. */
int view_script_load(const char *file, float dt, script *s);
void script_free(script *s);

/* s with bytes outside printable ASCII as \xHH, cut to about 80 characters:
 * for quoting user text in messages. Returns buf. */
const char *view_printable(const char *s, char *buf, size_t cap);

#endif
