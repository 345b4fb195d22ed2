/* horizon view --terrain NAME.hzp: fly over a streamed pyramid in a window.
 * The frame never waits for the disk or the network: decoded tiles are
 * uploaded as they come, and arriving tiles slide in. The keys, mouse,
 * scripts (--script, --frames, --screenshot, --dt) and the compact HUD are
 * those of the in-memory view. A real place's sea is drawn (stream_water);
 * the other effects, forests and city models are not drawn on a streamed
 * terrain. */
#include "stream_cli.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "horizon/flycam.h"
#include "horizon/path.h"
#include "horizon/safety.h"
#include "horizon/window.h"
#include "json_out.h"
#include "view_common.h"
#include "view_input.h"

typedef struct sview {
    sopts o;
    sctx c;
    hz_window *win;
    hz_overlay *ov;
    hz_flycam fc;
    script sc;
    hz_path path;
    bool path_active;
    double path_t, clock;
    uint32_t width, height, frame, shots;
    float look_yaw, look_pitch;
    bool hud;
    /* figures */
    double last_ms, fps_t0, fps, frame_ms;
    uint32_t fps_frames;
    hz_lod_stats st;
    hz_stream_stats ss;
    uint64_t late_frames, loaded;
    double worst_ms;
    char message[200];
    double message_until;
    hz_err err;
} sview;

static float ground(void *user, float x, float z)
{
    const float h = hz_stream_height_at(user, x, z);
    return isfinite(h) ? h : -1e30f;
}

static bool write_shot(sview *v, const char *file)
{
    hz_err err = {0};
    const bool ok = view_write_png(v->c.r, v->width, v->height, file, &err);
    if (ok && !v->o.quiet)
        fprintf(stderr, "horizon view: wrote %s (%ux%u)\n", file, v->width, v->height);
    if (!ok)
        fprintf(stderr, "horizon view: screenshot %s failed: %s\n", file, err.msg);
    snprintf(v->message, sizeof v->message, ok ? "saved %s" : "screenshot %s failed", file);
    v->message_until = hz_time_ms() + 3000.0;
    v->shots += ok;
    return ok;
}

static bool run_script(sview *v, const char **shot)
{
    view_script_out o = {0};
    view_script_step(&v->sc, v->frame, v->win, &v->fc, &o);
    v->look_yaw += o.look_yaw;
    v->look_pitch += o.look_pitch;
    if (o.camera_set)
        v->path_active = false;
    *shot = o.shot;
    return !o.quit;
}

static void hud(sview *v)
{
    const float sc = v->height >= 600 ? 2.0f : 1.0f, lh = 12.0f * sc, x0 = 6.0f * sc;
    static const float white[4] = {1, 1, 1, 1}, panel[4] = {0.02f, 0.03f, 0.06f, 0.55f}, on[4] = {1, 0.85f, 0.25f, 1};
    char lines[4][112];
    snprintf(lines[0], sizeof lines[0], "%.1f FPS  %.1f ms", v->fps, v->frame_ms);
    snprintf(lines[1], sizeof lines[1], "cdlod %.3g px  %.0fk tris  %zu nodes", v->o.tau,
             (double)v->st.triangles / 1000.0, v->c.pl.count);
    snprintf(lines[2], sizeof lines[2], "tiles %u resident  %u pending  %.0f MB", v->ss.resident, v->ss.pending,
             (double)v->ss.cache_bytes / 1048576.0);
    const float g = hz_flycam_ground(&v->fc);
    snprintf(lines[3], sizeof lines[3], "alt %.0f m  +%.0f m", (double)v->fc.cam.pos[1],
             isfinite(g) && g > -1e29f ? (double)(v->fc.cam.pos[1] - g) : 0.0);
    float w = 0;
    for (int k = 0; k < 4; k++) {
        float tw;
        hz_overlay_text_size(lines[k], sc, &tw, NULL);
        w = tw > w ? tw : w;
    }
    hz_overlay_rect(v->ov, 0, 0, w + 2 * x0, 4.0f * lh + 2 * x0, panel);
    for (int k = 0; k < 4; k++)
        hz_overlay_text(v->ov, x0, x0 + (float)k * lh, sc, white, lines[k]);
    if (v->message[0] && hz_time_ms() < v->message_until)
        hz_overlay_text(v->ov, x0, (float)v->height - lh - x0, sc, on, v->message);
}

/* One frame: input, camera, tiles, selection, draw. False to stop. */
static bool frame(sview *v, bool *failed)
{
    const char *shot = NULL;
    bool go = run_script(v, &shot);
    hz_window_input in;
    hz_window_poll(v->win, &in);
    go = go && !in.close_requested;
    for (uint32_t k = 0; k < in.press_count; k++) {
        const int key = in.presses[k];
        if (key == HZ_KEY_ESCAPE)
            go = false;
        else if (key == HZ_KEY_F1 + 5 || key == HZ_KEY_A + ('H' - 'A'))
            v->hud = !v->hud;
        else if (key == HZ_KEY_F1 + 11 || key == HZ_KEY_A + ('P' - 'A')) {
            char file[64];
            snprintf(file, sizeof file, "horizon_stream_%u.png", v->shots + 1);
            write_shot(v, file);
        } else if (key == HZ_KEY_TAB)
            hz_flycam_set_mode(&v->fc, v->fc.mode == HZ_FLYCAM_FREE ? HZ_FLYCAM_VIEWER : HZ_FLYCAM_FREE);
    }
    if (in.fb_width == 0 || in.fb_height == 0) {
        if (go)
            hz_window_wait(v->win, 0.1);
        return go;
    }
    if (in.fb_width != v->width || in.fb_height != v->height) {
        if (hz_renderer_resize(v->c.r, in.fb_width, in.fb_height, &v->err) != HZ_OK) {
            *failed = true;
            return false;
        }
        v->width = in.fb_width, v->height = in.fb_height;
        v->c.lp.viewport_height = v->height;
    }
    const double now = hz_time_ms();
    const float dt = v->o.dt > 0 ? (float)v->o.dt : (float)fmin(fmax((now - v->last_ms) / 1000.0, 0.0), 0.25);
    v->frame_ms = now - v->last_ms;
    v->last_ms = now;
    v->fps_frames++;
    if (now - v->fps_t0 >= 500.0) {
        v->fps = 1000.0 * v->fps_frames / (now - v->fps_t0);
        v->fps_frames = 0;
        v->fps_t0 = now;
    }
    /* camera */
    v->fc.cam.aspect = (float)v->width / (float)v->height;
    if (in.scroll != 0.0f)
        hz_flycam_scroll_speed(&v->fc, in.scroll);
    if (v->path_active) {
        v->path_t += dt;
        hz_path_sample(&v->path, (float)v->path_t, &v->fc.cam);
        v->path_active = v->path_t < (double)hz_path_duration(&v->path);
    } else {
        const hz_flycam_input fi = view_flycam_input(v->win, &in, dt, v->look_yaw, v->look_pitch, 0.15f);
        hz_flycam_update(&v->fc, &fi, dt);
    }
    v->look_yaw = v->look_pitch = 0.0f;
    hz_stream_wrap_camera(v->c.s, &v->fc.cam);
    /* tiles that arrived, then the selection over them */
    uint32_t n;
    if (upload_ready(&v->c, &n)) {
        *failed = true;
        return false;
    }
    v->clock += dt;
    hz_stream_set_clock(v->c.s, v->clock);
    if (hz_stream_select(v->c.s, &v->fc.cam, &v->c.lp, &v->c.pl, &v->st) != HZ_OK) {
        hz_err_set(&v->err, HZ_ERR_MEMORY, "out of memory in the selection");
        *failed = true;
        return false;
    }
    v->ss = hz_stream_take_stats(v->c.s);
    v->loaded += v->ss.loaded;
    v->late_frames += v->ss.late > 0;
    hz_scene_params sp = {.patches = v->c.pl.data, .patch_count = (uint32_t)v->c.pl.count,
                          .morph_scale = v->st.morph_scale, .morph_start = v->st.morph_start,
                          .morph_near = v->st.morph_near, .morph_near_distance = v->st.morph_near_distance,
                          .fog_density = cli_fog_default(v->fc.cam.zfar), .effects = stream_effects(&v->c)};
    hz_draw_stats ds = {0};
    if (hz_renderer_draw(v->c.r, &v->fc.cam, &sp, NULL, 0, &ds, &v->err) != HZ_OK) {
        *failed = true;
        return false;
    }
    if (v->hud)
        hud(v);
    hz_overlay_frame fr = {.cam = &v->fc.cam, .width = v->width, .height = v->height};
    if (hz_overlay_draw(v->ov, &fr, &v->err) != HZ_OK) {
        *failed = true;
        return false;
    }
    if (v->frame > 0 && v->frame_ms > v->worst_ms)
        v->worst_ms = v->frame_ms;
    v->frame++;
    if (v->o.frames && v->frame >= v->o.frames)
        go = false;
    if (shot && !write_shot(v, shot))
        *failed = true;
    if (!go && v->o.screenshot && !write_shot(v, v->o.screenshot))
        *failed = true;
    hz_window_swap(v->win);
    return go && !*failed;
}

int stream_view(int argc, char **argv)
{
    static sview v; /* large; one per process */
    memset(&v, 0, sizeof v);
    int rc = parse_stream(argc, argv, &v.o, "view");
    if (rc)
        return rc;
    if (v.o.screenshot && hz_same_file(v.o.screenshot, v.o.terrain)) {
        fprintf(stderr, "horizon view: --screenshot '%s' is the --terrain; refusing to overwrite it\n", v.o.screenshot);
        return 2;
    }
    if (v.o.script && v.o.screenshot && hz_same_file(v.o.script, v.o.screenshot)) {
        fprintf(stderr, "horizon view: --screenshot '%s' is the --script; refusing to overwrite it\n", v.o.screenshot);
        return 2;
    }
    const float script_dt = v.o.dt > 0 ? (float)v.o.dt : 1.0f / 30.0f;
    if (v.o.script) {
        rc = view_script_load(v.o.script, script_dt, &v.sc);
        if (rc) {
            script_free(&v.sc);
            return rc;
        }
        if (v.o.dt <= 0)
            v.o.dt = script_dt; /* scripted runs replay the same frames */
    }
    if (v.o.path && hz_path_load_csv(v.o.path, &v.path, &v.err) != HZ_OK) {
        fprintf(stderr, "horizon view: %s\n", v.err.msg);
        script_free(&v.sc);
        return 2;
    }
    v.path_active = v.o.path != NULL;
    rc = 1;
    char title[256];
    snprintf(title, sizeof title, "horizon view - %s", v.o.terrain);
    v.win = hz_window_create(&(hz_window_desc){.width = v.o.width, .height = v.o.height, .title = title,
                                               .no_vsync = v.o.no_vsync},
                             &v.err);
    if (!v.win) {
        fprintf(stderr, "horizon view: %s\n", v.err.msg);
        goto out;
    }
    if (sctx_open(&v.c, &v.o, NULL, "view"))
        goto out;
    v.ov = hz_overlay_create(&v.err);
    if (!v.ov) {
        fprintf(stderr, "horizon view: %s\n", v.err.msg);
        goto out;
    }
    hz_window_framebuffer_size(v.win, &v.width, &v.height);
    if (hz_renderer_resize(v.c.r, v.width, v.height, &v.err) != HZ_OK) {
        fprintf(stderr, "horizon view: %s\n", v.err.msg);
        goto out;
    }
    v.c.lp.viewport_height = v.height;
    const hz_pyr_info *in = hz_stream_info(v.c.s);
    hz_camera cam = stream_camera(&v.o, &v.c, v.width, v.height);
    const double side = (double)(in->data_w > in->data_h ? in->data_w : in->data_h) * in->spacing;
    hz_flycam_init(&v.fc, &(hz_flycam_desc){.start = cam, .speed = (float)(v.o.speed > 0 ? v.o.speed : side / 200.0),
                                            .height = ground, .height_user = v.c.s});
    v.hud = !v.o.no_hud;
    if (!v.o.quiet)
        fprintf(stderr, "horizon view: %s streamed (%u x %u samples, %u levels, cache %u tiles); WASD/QE fly, "
                        "mouse drag looks, shift fast, P screenshot, H HUD, Esc quits\n",
                v.o.terrain, in->data_w, in->data_h, in->levels, hz_stream_slots(v.c.s));
    v.last_ms = v.fps_t0 = hz_time_ms();
    bool failed = false;
    while (frame(&v, &failed)) {
    }
    if (failed) {
        fprintf(stderr, "horizon view: %s\n", v.err.msg[0] ? v.err.msg : "failed");
        goto out;
    }
    if (hz_stream_warning(v.c.s))
        fprintf(stderr, "horizon view: warning: %s\n", hz_stream_warning(v.c.s));
    if (v.o.json) {
        json_t *j = json_object();
        jx_set(j, "terrain", jx_str(v.o.terrain));
        jx_set(j, "frames", jx_int(v.frame));
        jx_set(j, "camera", json_pack("[ooooo]", jx_fix(v.fc.cam.pos[0], 3), jx_fix(v.fc.cam.pos[1], 3),
                                      jx_fix(v.fc.cam.pos[2], 3), jx_fix(v.fc.cam.yaw, 3), jx_fix(v.fc.cam.pitch, 3)));
        jx_set(j, "triangles", jx_int(v.st.triangles));
        jx_set(j, "nodes_drawn", jx_int((long long)v.c.pl.count));
        jx_set(j, "tiles_loaded", jx_int((long long)v.loaded));
        jx_set(j, "tiles_resident", jx_int(v.ss.resident));
        jx_set(j, "late_frame_fraction", jx_fix(v.frame ? (double)v.late_frames / v.frame : 0.0, 4));
        jx_set(j, "worst_frame_ms", jx_fix(v.worst_ms, 2));
        jx_set(j, "screenshots", jx_int(v.shots));
        jx_set(j, "gl", jx_str(hz_window_describe(v.win)));
        jx_print(j, stdout); /* releases j */
    }
    rc = 0;
out:
    hz_overlay_destroy(v.ov);
    sctx_free(&v.c);
    hz_window_destroy(v.win);
    hz_path_free(&v.path);
    script_free(&v.sc);
    return rc;
}
