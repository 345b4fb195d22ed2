/* Renders one frame of a terrain headless (EGL, no window) to a PNG.
 *   render_png OUT.png [DEM]       (no DEM: a generated 1025^2 terrain)
 * Build against an installed libhorizon:
 *   cc render_png.c $(pkg-config --cflags --libs horizon) -o render_png */
#include <stdio.h>
#include <stdlib.h>

#include <horizon/render.h>
#include <horizon/terrain.h>

enum { W = 640, H = 360 };

int main(int argc, char **argv)
{
    if (argc != 2 && argc != 3) {
        fprintf(stderr, "usage: render_png OUT.png [DEM]\n");
        return 2;
    }
    hz_err err = {0};
    hz_terrain_desc d = {.generate = HZ_GEN_PERLIN, .gen_size = 1025, .seed = 1};
    if (argc == 3)
        d = (hz_terrain_desc){.dem_path = argv[2]};
    hz_terrain *t = hz_terrain_create(&d, &err);
    hz_gl *gl = t ? hz_gl_create_headless(&err) : NULL;
    hz_renderer *r = gl ? hz_renderer_create(&(hz_renderer_desc){.width = W, .height = H}, &err) : NULL;
    hz_index_list il = {0};
    uint8_t *rgb = malloc((size_t)W * H * 3);
    int rc = 1;
    if (!r || !rgb || hz_renderer_set_heightmap(r, &t->hm, t->spacing, t->zscale, &err) != HZ_OK ||
        hz_renderer_set_valid(r, t->valid, &err) != HZ_OK)
        goto out;
    /* The default camera frames the highest ground; the LOD selects the
     * triangles for it (1 px screen-space error), masked samples dropped. */
    hz_camera cam = hz_terrain_default_camera(t, W, H);
    hz_lod_stats st;
    if (hz_lod_select(t->lod, &cam, &(hz_lod_params){.pixel_error = 1.0f, .viewport_height = H}, &il, NULL, NULL,
                      &st) != HZ_OK)
        goto out;
    il.count = hz_terrain_filter_triangles(t, il.data, il.count);
    if (hz_renderer_draw(r, &cam, NULL, il.data, (uint32_t)il.count, NULL, &err) != HZ_OK ||
        hz_renderer_read_rgb(r, rgb, &err) != HZ_OK || hz_image_write_png(argv[1], rgb, W, H, &err) != HZ_OK)
        goto out;
    printf("%s: %ux%u, %u triangles, camera %.0f %.0f %.0f\n", argv[1], W, H, st.triangles, (double)cam.pos[0],
           (double)cam.pos[1], (double)cam.pos[2]);
    rc = 0;
out:
    if (rc)
        fprintf(stderr, "render_png: %s\n", err.msg[0] ? err.msg : "failed");
    free(rgb);
    free(il.data);
    hz_renderer_destroy(r);
    hz_gl_destroy(gl);
    hz_terrain_destroy(t);
    return rc;
}
