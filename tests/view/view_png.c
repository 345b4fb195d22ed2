/* Classifies the pixels of a horizon view screenshot and prints the figures
 * as one JSON object, for test_view.sh to judge:
 *   sky      fraction of blue-sky pixels (blue well above red: the renderer's
 *            gradient from (0.72, 0.81, 0.92) to (0.20, 0.40, 0.78))
 *   terrain  fraction of clearly-not-sky pixels (blue not above red by much)
 *   red, white, blue   fan-view colours (centre red, rim white, finest blue)
 *   hud_text fraction of near-white pixels in the HUD corner (top-left
 *            40% x 25%), where the HUD's white text is
 * usage: view_png FILE.png */
#include <stdio.h>
#include <stdlib.h>

#define STB_IMAGE_IMPLEMENTATION
#define STBI_ONLY_PNG
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wconversion"
#pragma GCC diagnostic ignored "-Wsign-conversion"
#pragma GCC diagnostic ignored "-Wshadow"
#pragma GCC diagnostic ignored "-Wunused-function"
#pragma GCC diagnostic ignored "-Wmissing-braces"
#include <stb_image.h>
#pragma GCC diagnostic pop

int main(int argc, char **argv)
{
    if (argc != 2) {
        fprintf(stderr, "usage: view_png FILE.png\n");
        return 2;
    }
    int w, h, n;
    unsigned char *px = stbi_load(argv[1], &w, &h, &n, 3);
    if (!px) {
        fprintf(stderr, "view_png: cannot read %s: %s\n", argv[1], stbi_failure_reason());
        return 1;
    }
    size_t sky = 0, terrain = 0, red = 0, white = 0, blue = 0, hud = 0, hud_px = 0;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            const unsigned char *p = px + 3 * ((size_t)y * (size_t)w + (size_t)x);
            int r = p[0], g = p[1], b = p[2];
            if (b - r > 40 && b >= g)
                sky++;
            if (b - r < 25)
                terrain++;
            if (r > 150 && g < 120 && b < 120)
                red++;
            if (r > 215 && g > 215 && b > 215)
                white++;
            if (b > 150 && r < 110 && b - g > 60)
                blue++;
            if (x < w * 2 / 5 && y < h / 4) {
                hud_px++;
                if (r > 230 && g > 230 && b > 230)
                    hud++;
            }
        }
    double t = (double)w * (double)h;
    printf("{\"width\":%d,\"height\":%d,\"sky\":%.4f,\"terrain\":%.4f,\"red\":%.4f,\"white\":%.4f,"
           "\"blue\":%.4f,\"hud_text\":%.4f}\n",
           w, h, (double)sky / t, (double)terrain / t, (double)red / t, (double)white / t, (double)blue / t,
           hud_px ? (double)hud / (double)hud_px : 0.0);
    stbi_image_free(px);
    return 0;
}
