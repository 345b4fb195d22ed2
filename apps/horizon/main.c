/* horizon: command-line front end over libhorizon. */
#include "cli.h"

#include <stdio.h>
#include <string.h>

static void usage(void)
{
    fprintf(stderr, "usage: horizon <command> [options]\n"
                    "commands:\n"
                    "  render   render one frame of a terrain headless to PNG (--help for options)\n"
                    "  bench    fly a camera path headless and measure every frame (--help)\n"
                    "  view     open a window to fly over the terrain, HUD and debug views (--help)\n"
                    "  info     size, CRS, corners, spacing, heights and nodata of DEM files (--help)\n"
                    "  tree     grow/import a tree, rank its leaves by VMI, build its crown hull (--help)\n"
                    "  city     write a procedural city as a scene file (--help)\n");
}

int main(int argc, char **argv)
{
    if (argc < 2 || !strcmp(argv[1], "--help") || !strcmp(argv[1], "-h")) {
        usage();
        return argc < 2 ? 2 : 0;
    }
    if (!strcmp(argv[1], "render"))
        return cmd_render(argc, argv);
    if (!strcmp(argv[1], "bench"))
        return cmd_bench(argc, argv);
    if (!strcmp(argv[1], "tree"))
        return cmd_tree(argc, argv);
    if (!strcmp(argv[1], "info"))
        return cmd_info(argc, argv);
    if (!strcmp(argv[1], "view"))
        return cmd_view(argc, argv);
    if (!strcmp(argv[1], "city"))
        return cmd_city(argc, argv);
    fprintf(stderr, "horizon: unknown command '%s'\n", argv[1]);
    usage();
    return 2;
}
