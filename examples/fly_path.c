/* Flies the built-in "flyover" path over a generated terrain headless and
 * prints the bench figures: triangles, LOD and draw milliseconds per frame,
 * and their medians.
 *   fly_path [FRAMES]
 * Build against an installed libhorizon:
 *   cc fly_path.c $(pkg-config --cflags --libs horizon) -o fly_path */
#include <stdio.h>
#include <stdlib.h>

#include <horizon/path.h>
#include <horizon/render.h>
#include <horizon/terrain.h>

enum { W = 480, H = 270 };

static int cmp(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static double median(double *v, int n)
{
    qsort(v, (size_t)n, sizeof *v, cmp);
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

int main(int argc, char **argv)
{
    const int frames = argc > 1 ? atoi(argv[1]) : 10;
    if (frames < 1 || frames > 10000) {
        fprintf(stderr, "usage: fly_path [FRAMES in 1..10000]\n");
        return 2;
    }
    hz_err err = {0};
    hz_terrain *t = hz_terrain_create(&(hz_terrain_desc){.generate = HZ_GEN_PERLIN, .gen_size = 1025, .seed = 3}, &err);
    hz_gl *gl = t ? hz_gl_create_headless(&err) : NULL;
    hz_renderer *r = gl ? hz_renderer_create(&(hz_renderer_desc){.width = W, .height = H}, &err) : NULL;
    hz_path path = {0};
    hz_index_list il = {0};
    double *lod_ms = calloc((size_t)frames, sizeof *lod_ms), *draw_ms = calloc((size_t)frames, sizeof *draw_ms);
    double *tris = calloc((size_t)frames, sizeof *tris);
    int rc = 1;
    if (!r || !lod_ms || !draw_ms || !tris || hz_renderer_set_heightmap(r, &t->hm, t->spacing, t->zscale, &err) != HZ_OK ||
        hz_terrain_path(t, "flyover", &path, &err) != HZ_OK)
        goto out;
    const hz_lod_params lp = {.pixel_error = 1.0f, .viewport_height = H};
    printf("frame  triangles  lod_ms  draw_ms\n");
    for (int f = 0; f < frames; f++) {
        hz_camera cam = hz_terrain_default_camera(t, W, H); /* lens and clip planes */
        hz_path_sample(&path, 60.0f * (float)f / (float)frames, &cam);
        hz_lod_stats st;
        hz_draw_stats ds;
        if (hz_lod_select(t->lod, &cam, &lp, &il, NULL, NULL, &st) != HZ_OK ||
            hz_renderer_draw(r, &cam, NULL, il.data, (uint32_t)il.count, &ds, &err) != HZ_OK)
            goto out;
        lod_ms[f] = st.ms;
        draw_ms[f] = ds.draw_ms;
        tris[f] = st.triangles;
        printf("%5d  %9u  %6.3f  %7.2f\n", f, st.triangles, st.ms, ds.draw_ms);
    }
    printf("median %9.0f  %6.3f  %7.2f  (%d frames, %ux%u)\n", median(tris, frames), median(lod_ms, frames),
           median(draw_ms, frames), frames, W, H);
    rc = 0;
out:
    if (rc)
        fprintf(stderr, "fly_path: %s\n", err.msg[0] ? err.msg : "failed");
    free(lod_ms);
    free(draw_ms);
    free(tris);
    free(il.data);
    hz_path_free(&path);
    hz_renderer_destroy(r);
    hz_gl_destroy(gl);
    hz_terrain_destroy(t);
    return rc;
}
