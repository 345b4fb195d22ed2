/* horizon: command-line front end over libhorizon. */
#include "cli.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static void usage(void)
{
    fprintf(stderr, "usage: horizon <command> [options]\n"
                    "commands:\n"
                    "  render   render one frame of a terrain headless to PNG (--help for options)\n"
                    "  bench    fly a camera path headless and measure every frame (--help)\n"
                    "  view     open a window to fly over the terrain, HUD and debug views (--help)\n"
                    "  info     size, CRS, corners, spacing, heights and nodata of DEM files (--help)\n"
                    "  import   DEM files or a generated terrain to a streamed pyramid (.hzp) (--help)\n"
                    "  tree     grow/import a tree, rank its leaves by VMI, build its crown hull (--help)\n"
                    "  city     write a procedural city as a scene file (--help)\n"
                    "options are --name VALUE or --name=VALUE; horizon --version prints the version\n");
}

static void version(void)
{
    printf("horizon %s\n", HZ_VERSION);
}

int main(int argc, char **argv)
{
    if (argc < 2 || !strcmp(argv[1], "--help") || !strcmp(argv[1], "-h")) {
        usage();
        return argc < 2 ? 2 : 0;
    }
    if (!strcmp(argv[1], "--version") || !strcmp(argv[1], "-V")) {
        version();
        return 0;
    }
    /* Pyramids: import and streamed render/bench parse their own options (getopt_long). */
    if (!strcmp(argv[1], "import"))
        return cmd_import(argc, argv);
    if (!strcmp(argv[1], "city"))
        return cmd_city(argc, argv);
    if ((!strcmp(argv[1], "render") || !strcmp(argv[1], "bench") || !strcmp(argv[1], "view")) &&
        cli_wants_stream(argc, argv, 2))
        return !strcmp(argv[1], "render") ? stream_render(argc, argv)
               : !strcmp(argv[1], "bench") ? stream_bench(argc, argv)
                                           : stream_view(argc, argv);
    static const struct {
        const char *name;
        int (*fn)(int, char **);
    } cmds[] = {{"render", cmd_render}, {"bench", cmd_bench}, {"tree", cmd_tree}, {"info", cmd_info},
                {"view", cmd_view}};
    for (size_t k = 0; k < sizeof cmds / sizeof *cmds; k++)
        if (!strcmp(argv[1], cmds[k].name)) {
            int n;
            char **v;
            int rc = cli_args_normalize(cmds[k].name, argc, argv, &n, &v);
            if (rc)
                return rc;
            for (int i = 2; i < n; i++)
                if (!strcmp(v[i], "--version")) {
                    version();
                    free(v);
                    return 0;
                }
            rc = cmds[k].fn(n, v);
            free(v);
            return rc;
        }
    fprintf(stderr, "horizon: unknown command '%s'\n", argv[1]);
    usage();
    return 2;
}
