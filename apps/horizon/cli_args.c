/* The command line's syntax through getopt_long: each command's options are
 * declared once (name, takes a value or not); getopt_long reads the command
 * line (--name value, --name=value, unambiguous prefixes, -h, -q, "--"),
 * refuses unknown options with the nearest name suggested, and hands the
 * commands a normalised argv ("--name" "value" ...) whose values their
 * parsers check (ranges, formats: the messages of cli.c and the commands). */
#include "cli.h"

#include <getopt.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* Options every terrain command takes (cli_parse): with a value ... */
static const char *const COMMON_VALUE[] = {
    "amplitude", "bidir-distance", "bloom", "blur", "camera", "climate", "clouds", "colormap", "criterion", "crs",
    "dem", "dump-mesh", "effects", "exposure", "far", "fit", "fog", "forest", "forest-at", "forest-density",
    "forest-file", "forest-save", "forest-leaves", "forest-seed", "forest-trees", "format", "fov", "gamma", "generate", "height",
    "height-fog", "height-offset", "height-range", "hull-dist", "latitude", "layout", "lod", "lod-c", "lod-c2",
    "max-memory", "morph-start", "near", "near-error-distance", "near-pixel-error", "out", "patch-cells", "pixel-error", "rate-weights", "raw-size", "repeat",
    "roam-budget", "seed", "size", "spacing", "sun", "textures", "time", "tree-cache", "tree-far", "tree-near",
    "trees", "units", "voids", "water-level", "weather", "weather-intensity", "width", "wind", "zscale",
    "city", "scene", "footprints", "imagery", "imagery-max", "pick", "cull", "draw", "tin-cell", "height-field", "levels-field", "city-bench",
    "city-bench-frames", "curvature", "lit-map", NULL};
/* ... and flags. */
static const char *const COMMON_FLAG[] = {"no-cull",   "horizon-cull", "no-enlarge", "no-hysteresis", "no-node-cull", "no-simplify",
                                          "json",      "quiet",      "wireframe",     "help",         "version",
                                          NULL};
static const char *const BENCH_VALUE[] = {"effect-costs", "fps", "frames", "full-every", "json", "metrics",
                                          "path", "plot", "pr-res", "pr-shuffles", "pr-views", "reference", "save-frames",
                                          "tune-p99", "tune-silhouette", "tune-psnr", NULL};
static const char *const BENCH_FLAG[] = {"no-full", "no-pr", NULL};
static const char *const VIEW_VALUE[] = {"config", "dt", "eye-height", "frames", "hud-scale", "mouse-sens", "path",
                                         "screenshot", "script", "shot-dir", "speed", "walk-speed", NULL};
static const char *const VIEW_FLAG[] = {"boxes", "fans", "free", "no-hud", "hud-full", "no-vsync", "walk", NULL};
static const char *const TREE_VALUE[] = {"hull-grid", "hull-triangles", "import", "in", "layers", "leaf-match",
                                         "leaves", "min-elevation", "node-leaves", "out", "pr-res", "pr-shuffles", "pr-views", "preview",
                                         "rank-res", "rank-tree", "rate", "scale", "seed", "size", "species", "up", "views", "max-memory",
                                         NULL};
static const char *const TREE_FLAG[] = {"hull-preview", "json", "no-hull", "no-rank", "pr", "quiet", "rank", "help",
                                        NULL};
static const char *const INFO_VALUE[] = {"crs", NULL};
static const char *const INFO_FLAG[] = {"json", "help", "verify", NULL};

typedef struct opt_table {
    struct option *v;
    size_t n, cap;
} opt_table;

/* Adds names (a later entry of the same name replaces the earlier one: bench's
 * --json takes a file where render's is a flag). */
static bool add(opt_table *t, const char *const *names, int has_arg)
{
    for (; *names; names++) {
        size_t k = 0;
        while (k < t->n && strcmp(t->v[k].name, *names))
            k++;
        if (k == t->n) {
            if (t->n + 2 > t->cap) {
                size_t cap = t->cap ? 2 * t->cap : 128;
                struct option *v = realloc(t->v, cap * sizeof *v);
                if (!v)
                    return false;
                t->v = v;
                t->cap = cap;
            }
            t->n++;
        }
        t->v[k] = (struct option){*names, has_arg, NULL, 256 + (int)k};
        memset(&t->v[t->n], 0, sizeof t->v[t->n]);
    }
    return true;
}

static bool table_for(const char *cmd, opt_table *t)
{
    if (!strcmp(cmd, "info"))
        return add(t, INFO_VALUE, required_argument) && add(t, INFO_FLAG, no_argument);
    if (!strcmp(cmd, "tree"))
        return add(t, TREE_VALUE, required_argument) && add(t, TREE_FLAG, no_argument);
    if (!add(t, COMMON_VALUE, required_argument) || !add(t, COMMON_FLAG, no_argument))
        return false;
    if (!strcmp(cmd, "bench"))
        return add(t, BENCH_VALUE, required_argument) && add(t, BENCH_FLAG, no_argument);
    if (!strcmp(cmd, "view"))
        return add(t, VIEW_VALUE, required_argument) && add(t, VIEW_FLAG, no_argument);
    return true;
}

/* Damerau-Levenshtein distance (optimal string alignment). */
static size_t edit_distance(const char *a, const char *b)
{
    size_t la = strlen(a), lb = strlen(b);
    if (la > 64 || lb > 64)
        return 99;
    size_t d[65][65];
    for (size_t i = 0; i <= la; i++)
        d[i][0] = i;
    for (size_t j = 0; j <= lb; j++)
        d[0][j] = j;
    for (size_t i = 1; i <= la; i++)
        for (size_t j = 1; j <= lb; j++) {
            size_t s = d[i - 1][j - 1] + (a[i - 1] != b[j - 1]);
            size_t del = d[i - 1][j] + 1, ins = d[i][j - 1] + 1;
            d[i][j] = s < del ? (s < ins ? s : ins) : (del < ins ? del : ins);
            /* A swap of two neighbours is one edit (--jsno). */
            if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1] && d[i - 2][j - 2] + 1 < d[i][j])
                d[i][j] = d[i - 2][j - 2] + 1;
        }
    return d[la][lb];
}

const char *cli_args_nearest(const char *cmd, const char *arg)
{
    static char best_name[64];
    opt_table t = {0};
    if (!table_for(cmd, &t)) {
        free(t.v);
        return NULL;
    }
    while (*arg == '-')
        arg++;
    char word[64];
    snprintf(word, sizeof word, "%.*s", (int)strcspn(arg, "="), arg);
    size_t best = 99;
    best_name[0] = 0;
    for (size_t k = 0; k < t.n; k++) {
        size_t d = edit_distance(word, t.v[k].name);
        if (d < best) {
            best = d;
            snprintf(best_name, sizeof best_name, "--%s", t.v[k].name);
        }
    }
    free(t.v);
    const size_t len = strlen(word);
    return best_name[0] && best <= (len > 9 ? 3 : len > 4 ? 2 : 1) ? best_name : NULL;
}

int cli_args_normalize(const char *cmd, int argc, char **argv, int *out_argc, char ***out_argv)
{
    opt_table t = {0};
    char **out = calloc((size_t)argc * 2 + 2, sizeof *out);
    if (!out || !table_for(cmd, &t)) {
        free(out);
        free(t.v);
        fprintf(stderr, "horizon %s: out of memory\n", cmd);
        return 1;
    }
    int n = 0;
    out[n++] = argv[0];
    out[n++] = argv[1];
    /* getopt_long over argv[1..]: the command's name stands where a
     * program's would. "-": operands come back in order (code 1); ":" a
     * missing value is ':'. */
    opterr = 0;
    optind = 1;
    int rc = 0;
    for (;;) {
        int idx = -1;
        const int c = getopt_long(argc - 1, argv + 1, "-:hq", t.v, &idx);
        if (c == -1)
            break;
        const char *seen = argv[1 + optind - 1];
        if (c == 1) {
            out[n++] = optarg;
        } else if (c == 'h') {
            out[n++] = "--help";
        } else if (c == 'q') {
            out[n++] = "-q";
        } else if (c >= 256) {
            /* The option's full name (an unambiguous prefix expands). */
            static char names[256][72];
            const int k = c - 256;
            snprintf(names[k % 256], sizeof names[0], "--%s", t.v[k].name);
            out[n++] = names[k % 256];
            if (optarg)
                out[n++] = optarg;
        } else if (c == ':') {
            fprintf(stderr, "horizon %s: option %.*s needs a value\n", cmd, (int)strcspn(seen, "="), seen);
            rc = 2;
            break;
        } else {
            /* Unknown, ambiguous, or a value given to a flag (--json=x). */
            const char *arg = optopt && optopt < 256 ? NULL : seen;
            char shortopt[3] = {'-', (char)optopt, 0};
            /* The whole word: within a cluster of short options (-x.png)
             * getopt has not yet moved past it. */
            const char *elem = optopt && optopt < 256 && 1 + optind < argc && argv[1 + optind][0] == '-' &&
                                       argv[1 + optind][1] == (char)optopt
                                   ? argv[1 + optind]
                                   : seen;
            if (!arg)
                arg = shortopt;
            const char *near = cli_args_nearest(cmd, arg);
            const char *eq = strchr(arg, '=');
            bool flag_with_value = false;
            if (eq && arg[0] == '-' && arg[1] == '-') {
                for (size_t k = 0; k < t.n; k++)
                    if (t.v[k].has_arg == no_argument && strlen(t.v[k].name) == (size_t)(eq - arg - 2) &&
                        !strncmp(t.v[k].name, arg + 2, (size_t)(eq - arg - 2)))
                        flag_with_value = true;
            }
            if (flag_with_value)
                fprintf(stderr, "horizon %s: option %.*s takes no value\n", cmd, (int)(eq - arg), arg);
            else if (!strcmp(cmd, "info") && elem[0] == '-' && access(elem, F_OK) == 0) /* info takes files */
                fprintf(stderr, "horizon %s: unknown option '%s'; a file named '%s' goes after -- (horizon %s ... -- %s)\n",
                        cmd, arg, elem, cmd, elem);
            else if (near)
                fprintf(stderr, "horizon %s: unknown option '%s'; did you mean %s? (see horizon %s --help)\n", cmd,
                        arg, near, cmd);
            else
                fprintf(stderr, "horizon %s: unknown option '%s' (see horizon %s --help)\n", cmd, arg, cmd);
            rc = 2;
            break;
        }
    }
    free(t.v);
    if (rc) {
        free(out);
        return rc;
    }
    /* "--" ends the options: what follows are operands (a file named
     * -x.png), handed on after a "--" of their own. */
    if (1 + optind < argc) {
        out[n++] = "--";
        for (int k = 1 + optind; k < argc; k++)
            out[n++] = argv[k];
    }
    out[n] = NULL;
    *out_argc = n;
    *out_argv = out;
    return 0;
}
