/* horizon view: an interactive window to fly over a terrain, with a HUD and
 * debug views (wireframe, the seed's two-colour fans, a frozen LOD camera with
 * its frustum and culled nodes, node boxes). Scriptable for tests and demos:
 * --script (timed input events), --path (a camera path), --frames N,
 * --screenshot FILE. Settings may come from a `key = value` config file. */
#include "cli.h"

#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "horizon/flycam.h"
#include "horizon/gl_limits.h"
#include "horizon/safety.h"
#include "horizon/window.h"
#include "view_common.h"
#include "view_input.h"

#define MAX_BOXES 30000u /* node boxes drawn per frame (leaves and culled) */

/* ---- options --------------------------------------------------------------- */

typedef struct view_opts {
    const char *config, *script, *screenshot, *shot_dir, *path;
    uint32_t frames;      /* 0: until the window closes */
    float dt;             /* fixed seconds per frame; 0 -> real time (1/30 for scripted runs) */
    float speed;          /* m/s; 0 -> map side / 200 */
    float walk_speed;     /* m/s in walk mode; 0 -> 10 */
    float eye_height;     /* walk mode, metres; 0 -> 1.8 */
    float hud_scale;      /* 0 -> 2 for windows >= 600 px high, else 1 */
    float mouse_sens;     /* degrees per pixel; 0 -> 0.15 */
    bool walk, free_cam, fans, boxes, no_hud, hud_full, no_vsync;
} view_opts;

static void usage(void)
{
    fprintf(stderr, "usage: horizon view [terrain, LOD and view options as in render] [view options]\n"
                    "Opens a window to fly over the terrain (X11; xvfb-run for none).\n");
    cli_usage_terrain();
    cli_usage_forest();
    city_cli_usage();
    fprintf(stderr,
            "view:\n"
            "  --config FILE           settings as 'key = value' lines (keys are these long option\n"
            "                          names, flags take true/false); the command line wins\n"
            "  --speed M               flying speed in m/s (default: map side / 200); scroll changes it\n"
            "  --walk                  start in walk mode (eye kept --eye-height above the ground)\n"
            "  --eye-height M          walk mode eye height (default 1.8)\n"
            "  --walk-speed M          walk mode speed in m/s (default 10)\n"
            "  --free                  start with the free camera instead of the viewer camera\n"
            "  --fans / --boxes        start with the fan view / node boxes on (--wireframe too)\n"
            "  --no-hud                start with the HUD hidden\n"
            "  --hud-full              start with the full HUD (default: the compact corner; F6 switches)\n"
            "  --hud-scale S           HUD text size (default 2, 1 below 600 px)\n"
            "  --mouse-sens D          mouse look degrees per pixel (default 0.15)\n"
            "  --no-vsync              do not wait for the display (measure FPS)\n"
            "  --shot-dir DIR          where P/F12 screenshots go (default .)\n"
            "scripted runs:\n"
            "  --script FILE           timed input events (see README: 'horizon view')\n"
            "  --path NAME|FILE.csv    fly a camera path (flyover, orbit, ground, forest (with --forest)\n"
            "                          or t,x,y,z,yaw,pitch CSV)\n"
            "  --frames N              quit after N frames\n"
            "  --dt S                  fixed seconds per frame (default: real time; 1/30 with\n"
            "                          --script, --path or --frames)\n"
            "  --screenshot FILE.png   write the last frame when quitting\n"
            "  --json                  print a summary (frames, FPS, size, camera) as JSON on exit\n"
            "keys: WASD move, Q/E down/up, shift fast, ctrl slow, mouse drag (or M) look, arrows turn,\n"
            "      scroll speed, Tab viewer/free, G walk, 1/2 C, 3/4 C2, K culling, F1 HUD, F6 full HUD, H help,\n"
            "      F2 wireframe, F3 fans, F4 freeze LOD camera, F5 node boxes, R reset, P/F12 shot, Esc quit,\n"
            "      with --forest: T tree simplification on/off, Y hysteresis on/off\n"
            "effect keys: U sky, F flare, J shadows, I detail, B billboards, O fog, V water, N weather,\n"
            "      C rain/snow, X motion blur, Z bloom, [ ] sun azimuth, - = sun elevation\n");
}

/* Takes our options out of args, leaves the rest (argv[0], "view", ...) in
 * rest for cli_parse. Later occurrences win. Returns 0, or 2 (message printed). */
static int split_view_opts(int n, char **args, view_opts *vo, char **rest, int *nrest)
{
    for (int i = 2; i < n; i++) {
        const char *a = args[i], *v = i + 1 < n ? args[i + 1] : NULL;
        if (!strcmp(a, "--walk")) { vo->walk = true; continue; }
        if (!strcmp(a, "--free")) { vo->free_cam = true; continue; }
        if (!strcmp(a, "--fans")) { vo->fans = true; continue; }
        if (!strcmp(a, "--boxes")) { vo->boxes = true; continue; }
        if (!strcmp(a, "--no-hud")) { vo->no_hud = true; continue; }
        if (!strcmp(a, "--hud-full")) { vo->hud_full = true; continue; }
        if (!strcmp(a, "--no-vsync")) { vo->no_vsync = true; continue; }
        static const char *const valued[] = {"--config", "--script", "--screenshot", "--shot-dir", "--path",
                                             "--frames", "--dt", "--speed", "--walk-speed", "--eye-height",
                                             "--hud-scale", "--mouse-sens"};
        bool takes = false;
        for (size_t k = 0; k < sizeof valued / sizeof valued[0]; k++)
            takes = takes || !strcmp(a, valued[k]);
        if (!takes) {
            rest[(*nrest)++] = args[i];
            continue;
        }
        if (!v) {
            fprintf(stderr, "horizon view: option %s needs a value\n", a);
            return 2;
        }
        i++;
        bool ok = true;
        const char *want = "";
        if (!strcmp(a, "--config")) vo->config = v;
        else if (!strcmp(a, "--script")) vo->script = v;
        else if (!strcmp(a, "--screenshot")) vo->screenshot = v;
        else if (!strcmp(a, "--shot-dir")) vo->shot_dir = v;
        else if (!strcmp(a, "--path")) vo->path = v;
        else if (!strcmp(a, "--frames")) { ok = cli_parse_u32(v, 1, 100000000, &vo->frames); want = "a count in [1, 100000000]"; }
        else if (!strcmp(a, "--dt")) { ok = cli_parse_float(v, 1e-4, 10.0, &vo->dt); want = "seconds in [0.0001, 10]"; }
        else if (!strcmp(a, "--speed")) { ok = cli_parse_float(v, 0.1, 100000.0, &vo->speed); want = "m/s in [0.1, 100000]"; }
        else if (!strcmp(a, "--walk-speed")) { ok = cli_parse_float(v, 0.1, 100000.0, &vo->walk_speed); want = "m/s in [0.1, 100000]"; }
        else if (!strcmp(a, "--eye-height")) { ok = cli_parse_float(v, 0.01, 100000.0, &vo->eye_height); want = "metres in [0.01, 100000]"; }
        else if (!strcmp(a, "--hud-scale")) { ok = cli_parse_float(v, 0.5, 8.0, &vo->hud_scale); want = "a number in [0.5, 8]"; }
        else if (!strcmp(a, "--mouse-sens")) { ok = cli_parse_float(v, 0.001, 10.0, &vo->mouse_sens); want = "degrees per pixel in [0.001, 10]"; }
        if (!ok) {
            fprintf(stderr, "horizon view: invalid value '%s' for %s: expected %s\n", v, a, want);
            return 2;
        }
    }
    return 0;
}

/* ---- scripts --------------------------------------------------------------- */

/* ---- the viewer ------------------------------------------------------------ */

typedef struct view {
    view_opts vo;
    cli_opts o;
    hz_window *win;
    hz_overlay *ov;
    hz_renderer *ren;
    hz_terrain *t;
    cli_forest *cf;              /* --forest */
    city_app *ca;                /* --city / --scene / --footprints */
    bool left_was;               /* left button down last frame */
    float click_move;            /* cursor motion since the press (a click picks) */
    hz_flycam fc;
    hz_camera start_cam;
    float base_znear;
    float fly_speed, walk_speed; /* the speed of the other mode, kept while in one */
    hz_camera lod_cam;           /* the frozen LOD camera */
    hz_lod_params lod;
    bool morph_uploaded;         /* cdlod morph data is on the GPU */
    bool frozen, wire, fans, boxes, hud, help;
    bool hud_full;               /* the full HUD (F6 toggles it); else the compact corner */
    hz_index_list il;
    hz_patch_list pl; /* cdlod: the nodes drawn */
    hz_node_list leaves, culled;
    hz_lod_stats st;
    hz_draw_stats ds;
    uint32_t width, height;
    float hud_scale;
    float hud_w, hud_h;          /* HUD panel this frame (0 when hidden) */
    /* Timing. */
    double last_ms, fps_t0, fps, frame_ms;
    uint32_t fps_n;
    double *frame_times;
    size_t frame_times_n, frame_times_cap;
    double run_t0;
    uint32_t frame;
    float dt_fixed;
    /* Scripted input. */
    script sc;
    float look_yaw, look_pitch;
    hz_path path;
    bool have_path, path_active;
    double path_t;
    uint32_t shots;
    char message[256];
    double message_until;
    hz_err err;
    /* Effects. */
    app_fx afx;
    double fx_time;      /* effect time: advances by dt, so scripted runs repeat exactly */
    bool cut;            /* the camera jumped: restart the motion blur */
} view;

static void set_message(view *v, double seconds, const char *fmt, ...) __attribute__((format(printf, 3, 4)));
static void set_message(view *v, double seconds, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(v->message, sizeof v->message, fmt, ap);
    va_end(ap);
    v->message_until = hz_time_ms() + seconds * 1000.0;
}

/* Ground under (x, z): bilinear over the four nearest samples (the eye moves
 * smoothly in walk mode), clamped to the map. World metres. */
static float ground_at(void *user, float x, float z)
{
    const hz_terrain *t = user;
    const uint32_t n = t->hm.size;
    const float m = (float)(n - 1);
    float fi = x / t->spacing, fj = z / t->spacing;
    fi = fi < 0 ? 0 : fi > m ? m : fi;
    fj = fj < 0 ? 0 : fj > m ? m : fj;
    uint32_t i0 = (uint32_t)fi, j0 = (uint32_t)fj;
    if (i0 >= n - 1)
        i0 = n - 2;
    if (j0 >= n - 1)
        j0 = n - 2;
    float fx = fi - (float)i0, fz = fj - (float)j0;
    float h00 = hz_heightmap_get(&t->hm, i0, j0), h10 = hz_heightmap_get(&t->hm, i0 + 1, j0);
    float h01 = hz_heightmap_get(&t->hm, i0, j0 + 1), h11 = hz_heightmap_get(&t->hm, i0 + 1, j0 + 1);
    float h = (h00 * (1 - fx) + h10 * fx) * (1 - fz) + (h01 * (1 - fx) + h11 * fx) * fz;
    return h * t->zscale;
}

static const float C_WHITE[4] = {1, 1, 1, 1};
static const float C_SHADOW[4] = {0, 0, 0, 0.85f};
static const float C_PANEL[4] = {0.02f, 0.03f, 0.06f, 0.55f};
static const float C_ON[4] = {1.0f, 0.85f, 0.25f, 1};
static const float C_DIM[4] = {0.75f, 0.78f, 0.82f, 1};

/* Text with a 1-unit drop shadow, legible over sky and snow alike. */
static void text(view *v, float x, float y, const float rgba[4], const char *s)
{
    float sc = v->hud_scale;
    hz_overlay_text(v->ov, x + sc, y + sc, sc, C_SHADOW, s);
    hz_overlay_text(v->ov, x, y, sc, rgba, s);
}

/* ---- loading screen ------------------------------------------------------- */

typedef struct loading {
    view *v;
    const char *what;
    double last;
    bool closed;
} loading;

static void draw_loading(loading *l, const char *label, uint64_t done, uint64_t total)
{
    view *v = l->v;
    hz_window_input in;
    hz_window_poll(v->win, &in);
    for (uint32_t k = 0; k < in.press_count; k++)
        if (in.presses[k] == HZ_KEY_ESCAPE)
            l->closed = true;
    if (in.close_requested)
        l->closed = true;
    if (in.fb_width == 0 || in.fb_height == 0)
        return;
    float W = (float)in.fb_width, H = (float)in.fb_height;
    float sc = in.fb_height >= 600 ? 2.0f : 1.0f;
    if (v->vo.hud_scale > 0)
        sc = v->vo.hud_scale;
    v->hud_scale = sc;
    char buf[512];
    snprintf(buf, sizeof buf, "Loading %s", l->what);
    float tw, th;
    hz_overlay_text_size(buf, sc * 1.5f, &tw, &th);
    hz_overlay_text(v->ov, (W - tw) * 0.5f, H * 0.42f, sc * 1.5f, C_WHITE, buf);
    double frac = total ? (double)done / (double)total : 0.0;
    snprintf(buf, sizeof buf, "%s  %3.0f%%", label ? label : "", 100.0 * frac);
    hz_overlay_text_size(buf, sc, &tw, &th);
    hz_overlay_text(v->ov, (W - tw) * 0.5f, H * 0.42f + 24 * sc, sc, C_DIM, buf);
    float bw = W * 0.5f, bh = 6 * sc, bx = W * 0.25f, by = H * 0.42f + 40 * sc;
    static const float track[4] = {1, 1, 1, 0.15f}, fill[4] = {0.45f, 0.70f, 1.0f, 1};
    hz_overlay_rect(v->ov, bx, by, bw, bh, track);
    hz_overlay_rect(v->ov, bx, by, bw * (float)frac, bh, fill);
    hz_overlay_frame fr = {.width = in.fb_width, .height = in.fb_height, .clear = true,
                           .clear_rgb = {0.10f, 0.13f, 0.18f}};
    hz_err err = {0};
    if (hz_overlay_draw(v->ov, &fr, &err) == HZ_OK)
        hz_window_swap(v->win);
}

static void loading_progress(void *user, const char *label, uint64_t done, uint64_t total)
{
    loading *l = user;
    if (!l->v->o.quiet)
        hz_progress_stderr(NULL, label, done, total);
    double now = hz_time_ms();
    if (done < total && done > 0 && now - l->last < 50.0)
        return;
    l->last = now;
    draw_loading(l, label, done, total);
}

/* ---- per-frame work ------------------------------------------------------- */

static void apply_walk_speed(view *v, bool walk)
{
    if (walk == v->fc.walk)
        return;
    if (walk) {
        v->fly_speed = v->fc.speed;
        v->fc.speed = v->walk_speed;
    } else {
        v->walk_speed = v->fc.speed;
        v->fc.speed = v->fly_speed;
    }
}

static void set_walk(view *v, bool walk)
{
    if (walk && v->fc.mode != HZ_FLYCAM_VIEWER)
        hz_flycam_set_mode(&v->fc, HZ_FLYCAM_VIEWER);
    apply_walk_speed(v, walk);
    hz_flycam_set_walk(&v->fc, walk);
}

static bool write_shot(view *v, const char *file)
{
    hz_err err = {0};
    const bool ok = view_write_png(v->ren, v->width, v->height, file, &err);
    if (ok) {
        v->shots++;
        if (!v->o.quiet)
            fprintf(stderr, "horizon view: wrote %s (%ux%u)\n", file, v->width, v->height);
        set_message(v, 3.0, "saved %s", file);
    } else {
        fprintf(stderr, "horizon view: screenshot %s failed: %s\n", file, err.msg);
        set_message(v, 5.0, "screenshot failed: %s", err.msg);
    }
    return ok;
}

static void interactive_shot(view *v)
{
    char file[1024];
    time_t now = time(NULL);
    struct tm tmv;
    localtime_r(&now, &tmv);
    char stamp[32];
    strftime(stamp, sizeof stamp, "%Y%m%d_%H%M%S", &tmv);
    snprintf(file, sizeof file, "%s/horizon_%s_%u.png", v->vo.shot_dir ? v->vo.shot_dir : ".", stamp, v->shots + 1);
    write_shot(v, file);
}

static void scale_lod(float *val, float def, float f)
{
    float cur = *val > 0 ? *val : def;
    cur *= f;
    *val = cur < 0.05f ? 0.05f : cur > 100000.0f ? 100000.0f : cur;
}

/* Switches the LOD mode, preparing its data (and cdlod's morph data on the
 * GPU) on first use. False (mode unchanged, message shown) on failure. */
static bool set_lod_mode(view *v, hz_lod_mode mode)
{
    if (hz_lod_prepare(v->t->lod, mode) != HZ_OK) {
        set_message(v, 3.0, "LOD mode %s: out of memory", hz_lod_mode_name(mode));
        return false;
    }
    if (mode == HZ_LOD_CDLOD && !v->morph_uploaded) {
        hz_err err = {0};
        if (cli_renderer_morph(v->ren, v->t, mode, &err) != HZ_OK) {
            set_message(v, 3.0, "cdlod: %s", err.msg);
            return false;
        }
        v->morph_uploaded = true;
    }
    v->lod.mode = mode;
    return true;
}

/* The effect toggles: key letter and HZ_FX_* bit, in HUD order. */
static const struct {
    char key;
    uint32_t bit;
    const char *label;
} fx_keys[] = {{'U', HZ_FX_SKY, "sky"},     {'F', HZ_FX_FLARE, "flare"},    {'J', HZ_FX_SHADOWS, "shadows"},
               {'I', HZ_FX_DETAIL, "detail"}, {'B', HZ_FX_BILLBOARDS, "trees"}, {'O', HZ_FX_FOG, "fog"},
               {'V', HZ_FX_WATER, "water"},  {'N', HZ_FX_WEATHER, "weather"}, {'X', HZ_FX_MOTIONBLUR, "blur"},
               {'Z', HZ_FX_BLOOM, "bloom"}};

/* Toggles and one-shot keys. Returns false to quit. */
static bool handle_press(view *v, int key)
{
    for (size_t k = 0; k < sizeof fx_keys / sizeof fx_keys[0]; k++)
        if (key == HZ_KEY_A + (fx_keys[k].key - 'A')) {
            v->afx.effects ^= fx_keys[k].bit;
            if (fx_keys[k].bit == HZ_FX_MOTIONBLUR)
                v->cut = true;
            set_message(v, 1.5, "%s %s", hz_fx_name((uint32_t)__builtin_ctz(fx_keys[k].bit)),
                        (v->afx.effects & fx_keys[k].bit) ? "on" : "off");
            return true;
        }
    switch (key) {
    case HZ_KEY_ESCAPE:
        return false;
    case HZ_KEY_TAB:
        if (v->fc.mode == HZ_FLYCAM_VIEWER) {
            apply_walk_speed(v, false);
            hz_flycam_set_mode(&v->fc, HZ_FLYCAM_FREE);
        } else {
            hz_flycam_set_mode(&v->fc, HZ_FLYCAM_VIEWER);
        }
        set_message(v, 1.5, "%s camera", v->fc.mode == HZ_FLYCAM_FREE ? "free" : "viewer");
        break;
    case HZ_KEY_A + ('G' - 'A'):
        set_walk(v, !v->fc.walk);
        set_message(v, 1.5, "walk mode %s", v->fc.walk ? "on" : "off");
        break;
    case HZ_KEY_A + ('M' - 'A'):
        hz_window_capture_mouse(v->win, !hz_window_mouse_captured(v->win));
        break;
    case HZ_KEY_A + ('T' - 'A'):
        if (v->cf) {
            v->o.forest.simplify = !v->o.forest.simplify;
            set_message(v, 1.5, "tree simplification %s", v->o.forest.simplify ? "on" : "off");
        }
        break;
    case HZ_KEY_A + ('Y' - 'A'):
        if (v->cf) {
            v->o.forest.hysteresis = !v->o.forest.hysteresis;
            set_message(v, 1.5, "LOD hysteresis %s", v->o.forest.hysteresis ? "on" : "off");
        }
        break;
    case HZ_KEY_A + ('R' - 'A'): {
        bool walk = v->fc.walk;
        hz_camera c = v->fc.cam;
        glm_vec3_copy(v->start_cam.pos, c.pos);
        c.yaw = v->start_cam.yaw;
        c.pitch = v->start_cam.pitch;
        v->fc.cam = c;
        hz_flycam_set_walk(&v->fc, walk);
        hz_flycam_set_mode(&v->fc, v->fc.mode);
        v->cut = true;
        break;
    }
    case HZ_KEY_A + ('K' - 'A'):
        v->lod.no_cull = !v->lod.no_cull;
        set_message(v, 1.5, "frustum culling %s", v->lod.no_cull ? "off" : "on");
        break;
    case HZ_KEY_A + ('H' - 'A'):
        v->help = !v->help;
        break;
    case HZ_KEY_A + ('P' - 'A'):
    case HZ_KEY_F1 + 11:
        interactive_shot(v);
        break;
    case HZ_KEY_F1:
        v->hud = !v->hud;
        break;
    case HZ_KEY_F1 + 5:
        /* F6: the full HUD (every figure) or the compact corner. */
        v->hud_full = !v->hud_full;
        v->hud = true;
        break;
    case HZ_KEY_F1 + 1:
        v->wire = !v->wire;
        break;
    case HZ_KEY_F1 + 2:
        v->fans = !v->fans;
        break;
    case HZ_KEY_F1 + 3:
        v->frozen = !v->frozen;
        if (v->frozen)
            v->lod_cam = v->fc.cam;
        set_message(v, 2.0, v->frozen ? "LOD camera frozen: fly away to see what it selected and culled"
                                       : "LOD camera follows the view again");
        break;
    case HZ_KEY_F1 + 4:
        v->boxes = !v->boxes;
        break;
    case HZ_KEY_LEFT_BRACKET:
    case HZ_KEY_RIGHT_BRACKET:
    case HZ_KEY_MINUS:
    case HZ_KEY_EQUAL: {
        float az, el;
        app_fx_sun_angles(&v->afx, &az, &el);
        if (key == HZ_KEY_LEFT_BRACKET || key == HZ_KEY_RIGHT_BRACKET)
            az = fmodf(az + (key == HZ_KEY_RIGHT_BRACKET ? 15.0f : -15.0f) + 360.0f, 360.0f);
        else
            el = glm_clamp(el + (key == HZ_KEY_EQUAL ? 5.0f : -5.0f), -10.0f, 90.0f);
        if (app_fx_set_sun(&v->afx, v->t, v->ren, az, el))
            set_message(v, 3.0, "light map failed");
        else
            set_message(v, 2.0, "sun azimuth %.0f, elevation %.0f (light map %.0f ms)", (double)az, (double)el,
                        v->afx.lightmap_ms);
        break;
    }
    case HZ_KEY_A + ('C' - 'A'):
        v->afx.fx.weather = v->afx.fx.weather == HZ_WEATHER_SNOW ? HZ_WEATHER_RAIN : HZ_WEATHER_SNOW;
        set_message(v, 1.5, "weather: %s%s", v->afx.fx.weather == HZ_WEATHER_SNOW ? "snow" : "rain",
                    (v->afx.effects & HZ_FX_WEATHER) ? "" : " (N turns it on)");
        break;
    case HZ_KEY_0 + 1:
        scale_lod(&v->lod.c, 25.0f, 1.0f / 1.25f);
        break;
    case HZ_KEY_0 + 2:
        scale_lod(&v->lod.c, 25.0f, 1.25f);
        break;
    case HZ_KEY_0 + 3:
        scale_lod(&v->lod.c2, 2.5f, 1.0f / 1.25f);
        break;
    case HZ_KEY_0 + 4:
        scale_lod(&v->lod.c2, 2.5f, 1.25f);
        break;
    case HZ_KEY_0 + 5:
        scale_lod(&v->lod.pixel_error, 1.0f, 1.0f / 1.25f);
        break;
    case HZ_KEY_0 + 6:
        scale_lod(&v->lod.pixel_error, 1.0f, 1.25f);
        break;
    case HZ_KEY_A + ('L' - 'A'): {
        hz_lod_mode next = (hz_lod_mode)((v->lod.mode + 1) % HZ_LOD_MODE_COUNT);
        if (set_lod_mode(v, next))
            set_message(v, 2.0, "LOD mode %s", hz_lod_mode_name(next));
        break;
    }
    default:
        break;
    }
    return true;
}

/* Applies this frame's script events. Returns false on a quit event. */
static bool run_script(view *v, bool *shot_after, const char **shot_file)
{
    view_script_out o = {0};
    view_script_step(&v->sc, v->frame, v->win, &v->fc, &o);
    v->look_yaw += o.look_yaw;
    v->look_pitch += o.look_pitch;
    if (o.camera_set) {
        v->path_active = false;
        v->cut = true;
    }
    if (o.shot) {
        *shot_after = true;
        *shot_file = o.shot;
    }
    return !o.quit;
}

/* The seed's fan view: every LOD triangle is (centre, rim, rim) of its leaf's
 * fan; centre red, rim white; leaves of the finest level (half-size 1, all
 * rim samples adjacent to the centre) blue. */
static void queue_fans(view *v)
{
    const hz_terrain *t = v->t;
    const uint32_t n = t->hm.size;
    const size_t tris = v->il.count / 3;
    float *xyz;
    uint8_t *rgba;
    if (!tris || !hz_overlay_triangles(v->ov, tris, &xyz, &rgba)) {
        if (tris)
            set_message(v, 2.0, "fan view: out of memory");
        return;
    }
    static const uint8_t red[4] = {225, 35, 30, 255}, blue[4] = {40, 90, 235, 255}, white[4] = {255, 255, 255, 255};
    for (size_t k = 0; k < tris; k++) {
        const uint32_t *tri = v->il.data + 3 * k;
        uint32_t ci = tri[0] % n, cj = tri[0] / n;
        bool finest = true;
        for (int q = 1; q < 3; q++) {
            uint32_t i = tri[q] % n, j = tri[q] / n;
            if ((i > ci ? i - ci : ci - i) > 1 || (j > cj ? j - cj : cj - j) > 1)
                finest = false;
        }
        for (int q = 0; q < 3; q++) {
            uint32_t i = tri[q] % n, j = tri[q] / n;
            float *p = xyz + 9 * k + 3 * q;
            p[0] = (float)i * t->spacing;
            p[1] = v->st.morph_scale > 0 ? hz_lod_morph_height(t->lod, &v->fc.cam, &v->st, tri[q])
                                         : hz_heightmap_get(&t->hm, i, j) * t->zscale;
            p[2] = (float)j * t->spacing;
            memcpy(rgba + 12 * k + 4 * q, q == 0 ? (finest ? blue : red) : white, 4);
        }
    }
}

static void queue_boxes(view *v, const hz_node_list *nodes, const float rgba[4], uint32_t *drawn)
{
    for (size_t k = 0; k < nodes->count && *drawn < MAX_BOXES; k++) {
        const hz_lod_node *nd = &nodes->data[k];
        vec3 box[2];
        if (hz_lod_node_box(v->t->lod, nd->x, nd->z, nd->half, box)) {
            hz_overlay_box(v->ov, box, rgba);
            (*drawn)++;
        }
    }
}

/* The compact HUD: a few short lines in the top-left corner, the view left
 * free (F6 shows every figure, F1 hides the HUD). */
static void queue_hud_compact(view *v)
{
    const float sc = v->hud_scale, lh = 12.0f * sc, x0 = 6.0f * sc;
    const hz_camera *c = &v->fc.cam;
    const float g = hz_flycam_ground(&v->fc);
    char lines[4][96];
    snprintf(lines[0], sizeof lines[0], "%.1f FPS  %.1f ms", v->fps, v->frame_ms);
    if (v->lod.mode == HZ_LOD_CDLOD || v->lod.mode == HZ_LOD_ROAM || v->lod.pixel_error > 0)
        snprintf(lines[1], sizeof lines[1], "%s %.3g px  %.0fk tris", hz_lod_mode_name(v->lod.mode),
                 (double)cli_pixel_error(&v->lod), (double)v->st.triangles / 1000.0);
    else
        snprintf(lines[1], sizeof lines[1], "%s C %.3g  %.0fk tris", hz_lod_mode_name(v->lod.mode),
                 (double)(v->lod.c > 0 ? v->lod.c : 25.0f), (double)v->st.triangles / 1000.0);
    snprintf(lines[2], sizeof lines[2], "alt %.0f m  +%.0f m", (double)c->pos[1], (double)(c->pos[1] - g));
    snprintf(lines[3], sizeof lines[3], "F6 more  H keys");
    float w = 0;
    for (int k = 0; k < 4; k++) {
        float tw;
        hz_overlay_text_size(lines[k], sc, &tw, NULL);
        w = tw > w ? tw : w;
    }
    v->hud_w = w + 2 * x0;
    v->hud_h = 4.0f * lh + 2 * x0;
    hz_overlay_rect(v->ov, 0, 0, v->hud_w, v->hud_h, C_PANEL);
    for (int k = 0; k < 4; k++)
        text(v, x0, x0 + (float)k * lh, k == 3 ? C_DIM : C_WHITE, lines[k]);
}

static void queue_hud(view *v, uint32_t boxes_drawn, size_t boxes_wanted)
{
    if (!v->hud_full) {
        (void)boxes_drawn;
        (void)boxes_wanted;
        queue_hud_compact(v);
        return;
    }
    const float sc = v->hud_scale, lh = 12.0f * sc, x0 = 8.0f * sc;
    char lines[14][256];
    int nl = 0;
    const hz_terrain *t = v->t;
    const hz_camera *c = &v->fc.cam;
    float g = hz_flycam_ground(&v->fc);
    snprintf(lines[nl++], 256, "horizon view  %s  %ux%u @ %.3g m  window %ux%u", t->source, t->hm.size, t->hm.size,
             (double)t->spacing, v->width, v->height);
    snprintf(lines[nl++], 256, "FPS %.1f   frame %.2f ms   LOD %.2f ms   draw %.2f ms", v->fps, v->frame_ms,
             v->st.ms, v->ds.upload_ms + v->ds.draw_ms);
    snprintf(lines[nl++], 256, "triangles %u   nodes %u visited, %u culled, %u hidden, %u drawn", v->st.triangles,
             v->st.nodes_visited, v->st.nodes_culled, v->st.hidden, v->st.leaves);
    if (v->lod.pixel_error > 0 || v->lod.mode == HZ_LOD_ROAM || v->lod.mode == HZ_LOD_CDLOD) {
        char near[64] = "";
        if (v->lod.mode == HZ_LOD_CDLOD && v->lod.near_pixel_error > cli_pixel_error(&v->lod))
            snprintf(near, sizeof near, ", %.3g px within %.0f m", (double)v->lod.near_pixel_error,
                     (double)(v->lod.near_distance > 0 ? v->lod.near_distance : HZ_LOD_NEAR_DISTANCE_DEFAULT));
        snprintf(lines[nl++], 256, "LOD %s (L)   pixel error %.3g px%s (5/6: -/+)%s", hz_lod_mode_name(v->lod.mode),
                 (double)(v->lod.pixel_error > 0 ? v->lod.pixel_error : 1.0f), near,
                 v->lod.no_cull ? "  NO CULLING" : "");
    }
    else
        snprintf(lines[nl++], 256, "LOD %s (L)   C %.2f   C2 %.3f   (1/2: C -/+, 3/4: C2 -/+)  %s%s",
                 hz_lod_mode_name(v->lod.mode), (double)(v->lod.c > 0 ? v->lod.c : 25.0f),
                 (double)(v->lod.c2 > 0 ? v->lod.c2 : 2.5f),
                 v->lod.criterion == HZ_LOD_UNCLAMPED ? "unclamped" : "clamped", v->lod.no_cull ? "  NO CULLING" : "");
    snprintf(lines[nl++], 256, "camera %s  pos %.1f %.1f %.1f  yaw %.1f  pitch %.1f  speed %.3g m/s",
             hz_flycam_mode_name(&v->fc), (double)c->pos[0], (double)c->pos[1], (double)c->pos[2], (double)c->yaw,
             (double)c->pitch, (double)v->fc.speed);
    snprintf(lines[nl++], 256, "ground %.1f m   above ground %.1f m%s", (double)g, (double)(c->pos[1] - g),
             v->path_active ? "   (on camera path)" : "");
    if (t->georef) { /* where the camera is on Earth */
        double ex, ny, lon, lat;
        hz_georef_local_to_crs(t->georef, c->pos[0], c->pos[2], &ex, &ny);
        int n = snprintf(lines[nl], 256, "%s  E %.1f  N %.1f", hz_georef_label(t->georef), ex, ny);
        if (n > 0 && n < 200 && hz_georef_crs_to_lonlat(t->georef, ex, ny, &lon, &lat, NULL) == HZ_OK)
            snprintf(lines[nl] + n, (size_t)(256 - n), "   lon %.5f  lat %.5f", lon, lat);
        nl++;
    }
    if (v->cf) {
        const hz_forest_frame *fr = &v->cf->frame;
        snprintf(lines[nl++], 256, "forest %u trees, %u in view (%u hulls)  %.2f M of %.2f M tris  %.1f ms CPU  %s%s",
                 fr->trees, fr->trees_in_frustum, fr->trees_hull, (double)fr->triangles_drawn / 1e6,
                 (double)fr->triangles_full / 1e6, v->cf->hook.draw_ms,
                 v->o.forest.simplify ? "T simplified" : "T FULL", v->o.forest.hysteresis ? "  Y hyst." : "");
    }
    if (v->ca) {
        const hz_scene_draw_stats *cs = &v->ca->hook.stats;
        snprintf(lines[nl++], 256, "objects %u, %u in frustum, %u unoccluded  %u draws  %u state changes  %.1f ms CPU",
                 cs->objects, cs->after_frustum, cs->after_occlusion, cs->draw_calls, cs->state_changes,
                 cs->draw_ms + v->ca->occ_ms);
    }
    float az, el;
    app_fx_sun_angles(&v->afx, &az, &el);
    snprintf(lines[nl++], 256, "sun az %.0f el %.0f ([ ] - =)   time %.1f s   trees %u   %s %u   water %s",
             (double)az, (double)el, v->fx_time, v->ds.billboards,
             v->afx.fx.weather == HZ_WEATHER_SNOW ? "snow" : "rain", v->ds.particles,
             v->ds.reflections ? "reflected" : "-");
    if (boxes_wanted > boxes_drawn)
        snprintf(lines[nl++], 256, "boxes: the first %u of %zu shown", boxes_drawn, boxes_wanted);
    int views_line = nl;
    lines[nl++][0] = 0;
    int fx_line = nl;
    lines[nl++][0] = 0;
    float w = 0;
    for (int k = 0; k < nl; k++) {
        float tw;
        hz_overlay_text_size(lines[k], sc, &tw, NULL);
        w = tw > w ? tw : w;
    }
    /* Debug-view line: each toggle lit when on. */
    struct {
        const char *label;
        bool on;
    } views[] = {{"F2 wire", v->wire}, {"F3 fans", v->fans}, {"F4 freeze", v->frozen}, {"F5 boxes", v->boxes},
                 {"H help", v->help}};
    float vw = 0;
    for (size_t k = 0; k < sizeof views / sizeof views[0]; k++) {
        float tw;
        hz_overlay_text_size(views[k].label, sc, &tw, NULL);
        vw += tw + 10 * sc;
    }
    w = vw > w ? vw : w;
    char fx_labels[sizeof fx_keys / sizeof fx_keys[0]][24];
    float fw = 0;
    for (size_t k = 0; k < sizeof fx_keys / sizeof fx_keys[0]; k++) {
        snprintf(fx_labels[k], sizeof fx_labels[k], "%c %s", fx_keys[k].key, fx_keys[k].label);
        float tw;
        hz_overlay_text_size(fx_labels[k], sc, &tw, NULL);
        fw += tw + 8 * sc;
    }
    w = fw > w ? fw : w;
    v->hud_w = w + 2 * x0;
    v->hud_h = (float)nl * lh + 2 * x0;
    hz_overlay_rect(v->ov, 0, 0, v->hud_w, v->hud_h, C_PANEL);
    for (int k = 0; k < nl; k++)
        if (k != views_line && k != fx_line)
            text(v, x0, x0 + (float)k * lh, C_WHITE, lines[k]);
    /* Effects line: each lit when on. */
    float fxx = x0;
    for (size_t k = 0; k < sizeof fx_keys / sizeof fx_keys[0]; k++) {
        text(v, fxx, x0 + (float)fx_line * lh, (v->afx.effects & fx_keys[k].bit) ? C_ON : C_DIM, fx_labels[k]);
        float tw;
        hz_overlay_text_size(fx_labels[k], sc, &tw, NULL);
        fxx += tw + 8 * sc;
    }
    float x = x0;
    for (size_t k = 0; k < sizeof views / sizeof views[0]; k++) {
        text(v, x, x0 + (float)views_line * lh, views[k].on ? C_ON : C_DIM, views[k].label);
        float tw;
        hz_overlay_text_size(views[k].label, sc, &tw, NULL);
        x += tw + 10 * sc;
    }
}

static void queue_help(view *v)
{
    static const char *help =
        "W A S D      move (viewer: level, free: along the view)\n"
        "Q E          down / up (walk mode: eye height)\n"
        "shift ctrl   fast / slow          scroll   speed\n"
        "mouse drag   look (M: capture)    arrows   turn\n"
        "Tab          viewer / free camera\n"
        "G            walk mode (viewer camera)\n"
        "1 2 / 3 4    C - + / C2 - +       K  culling on/off\n"
        "F1 HUD on/off   F6 full HUD / compact\n"
        "F2 wireframe   F3 fans (centre red, rim white,\n"
        "         finest blue)   F4 freeze LOD camera   F5 boxes\n"
        "R reset camera   P or F12 screenshot   H help   Esc quit\n"
        "Effects: U sky  F flare  J shadows  I detail  B trees\n"
        "         O fog  V water  N weather (C rain/snow)\n"
        "         X motion blur  Z bloom\n"
        "[ ] sun azimuth -/+   - = sun elevation -/+";
    const float sc = v->hud_scale;
    float tw, th;
    hz_overlay_text_size(help, sc, &tw, &th);
    float x = (float)v->width - tw - 8 * sc, y = 8 * sc;
    if (x - 8 * sc < v->hud_w) {
        /* No room beside the HUD: below it. */
        x = 8 * sc;
        y = v->hud_h + 8 * sc;
    }
    hz_overlay_rect(v->ov, x - 8 * sc, y - 8 * sc, tw + 16 * sc, th + 16 * sc, C_PANEL);
    text(v, x, y, C_WHITE, help);
}

static void frame_stats(view *v, double now)
{
    double ms = now - v->last_ms;
    v->last_ms = now;
    if (v->frame > 0) {
        v->frame_ms = v->frame_ms > 0 ? 0.8 * v->frame_ms + 0.2 * ms : ms;
        if (v->frame_times_n == v->frame_times_cap) {
            size_t cap = v->frame_times_cap ? 2 * v->frame_times_cap : 256;
            double *p = realloc(v->frame_times, cap * sizeof *p);
            if (p) {
                v->frame_times = p;
                v->frame_times_cap = cap;
            }
        }
        if (v->frame_times_n < v->frame_times_cap)
            v->frame_times[v->frame_times_n++] = ms;
    }
    v->fps_n++;
    if (v->fps == 0.0 && v->frame_ms > 0)
        v->fps = 1000.0 / v->frame_ms; /* until the first half second is measured */
    if (now - v->fps_t0 >= 500.0) {
        v->fps = 1000.0 * v->fps_n / (now - v->fps_t0);
        v->fps_n = 0;
        v->fps_t0 = now;
        char title[256];
        snprintf(title, sizeof title, "horizon view - %s - %.0f FPS", v->t->source, v->fps);
        hz_window_set_title(v->win, title);
    }
}

/* One frame: input -> camera -> LOD -> terrain -> overlays -> (screenshot).
 * Returns false when the viewer should stop after this frame. */
static bool frame(view *v, bool *render_failed)
{
    bool go = true, shot = false;
    const char *shot_file = NULL;
    go = run_script(v, &shot, &shot_file) && go;

    hz_window_input in;
    hz_window_poll(v->win, &in);
    if (in.close_requested)
        go = false;
    for (uint32_t k = 0; k < in.press_count; k++)
        go = handle_press(v, in.presses[k]) && go;
    if (in.fb_width == 0 || in.fb_height == 0) {
        /* Minimised: nothing to draw into. */
        if (go)
            hz_window_wait(v->win, 0.1);
        return go;
    }
    if (in.fb_width != v->width || in.fb_height != v->height) {
        if (hz_renderer_resize(v->ren, in.fb_width, in.fb_height, &v->err) != HZ_OK) {
            *render_failed = true;
            return false;
        }
        v->width = in.fb_width;
        v->height = in.fb_height;
    }
    v->hud_scale = v->vo.hud_scale > 0 ? v->vo.hud_scale : v->height >= 600 ? 2.0f : 1.0f;

    double now = hz_time_ms();
    float dt = v->dt_fixed > 0 ? v->dt_fixed : (float)fmin(fmax((now - v->last_ms) / 1000.0, 0.0), 0.25);
    frame_stats(v, now);

    /* Camera. */
    v->fc.cam.aspect = (float)v->width / (float)v->height;
    if (in.scroll != 0.0f)
        hz_flycam_scroll_speed(&v->fc, in.scroll);
    if (v->path_active) {
        v->path_t += dt;
        hz_path_sample(&v->path, (float)v->path_t, &v->fc.cam);
        if (v->path_t >= (double)hz_path_duration(&v->path))
            v->path_active = false;
    } else {
        const hz_flycam_input fi = view_flycam_input(v->win, &in, dt, v->look_yaw, v->look_pitch, v->vo.mouse_sens);
        hz_flycam_update(&v->fc, &fi, dt);
    }
    v->look_yaw = v->look_pitch = 0.0f;
    /* A click (press and release without dragging) picks what is under the cursor. */
    {
        const bool ld = hz_window_mouse_down(v->win, HZ_MOUSE_LEFT);
        if (ld && !v->left_was)
            v->click_move = 0;
        if (ld)
            v->click_move += fabsf(in.mouse_dx) + fabsf(in.mouse_dy);
        float cx, cy;
        if (!ld && v->left_was && v->click_move < 4.0f && hz_window_cursor(v->win, &cx, &cy)) {
            char line[400];
            city_app_pick_line(v->ca, v->t, &v->fc.cam, cx, cy, v->width, v->height, line, sizeof line);
            set_message(v, 6.0, "%s", line);
            city_app_pick(v->ca, v->t, &v->fc.cam, cx, cy, v->width, v->height, NULL);
            fflush(stdout);
        }
        v->left_was = ld;
    }
    /* Walking needs a near plane closer than the eye height. */
    v->fc.cam.znear = v->fc.walk ? fminf(v->base_znear, 0.25f * v->fc.eye_height) : v->base_znear;

    /* LOD with the LOD camera (the view camera unless frozen). */
    const hz_camera *lod_cam = v->frozen ? &v->lod_cam : &v->fc.cam;
    bool want_leaves = v->boxes, want_culled = v->frozen;
    v->lod.viewport_height = v->height;
    /* cdlod draws nodes (patches); the index list is only needed for the
     * debug overlays (fans, boxes, the frozen camera's culled nodes). */
    const bool patches = v->lod.mode == HZ_LOD_CDLOD;
    const bool need_list = !patches || v->fans || want_leaves || want_culled;
    v->il.count = 0;
    if ((need_list && hz_lod_select(v->t->lod, lod_cam, &v->lod, &v->il, want_leaves ? &v->leaves : NULL,
                                    want_culled ? &v->culled : NULL, &v->st) != HZ_OK) ||
        (patches && hz_lod_select_patches(v->t->lod, lod_cam, &v->lod, &v->pl, &v->st) != HZ_OK)) {
        hz_err_set(&v->err, HZ_ERR_MEMORY, "out of memory in LOD selection");
        *render_failed = true;
        return false;
    }
    /* Triangles touching nodata or padding are not drawn (cdlod: the patch shader's job). */
    if (!patches)
        v->il.count = hz_terrain_filter_triangles(v->t, v->il.data, v->il.count);

    /* Terrain (sky only in the fan view: the fans replace the shading). */
    v->fx_time += dt;
    hz_scene_params sp = {0};
    app_fx_params(&v->afx, v->t, &v->fc.cam, &v->lod, v->fx_time, &sp);
    sp.wireframe = v->wire;
    sp.reset_history = v->cut || v->frame == 0;
    v->cut = false;
    cli_scene_lod(&sp, &v->st);
    if (v->cf) {
        if (!cli_forest_update(v->cf, &v->o, &v->fc.cam, (now - v->run_t0) / 1000.0)) {
            hz_err_set(&v->err, HZ_ERR_MEMORY, "forest selection failed");
            *render_failed = true;
            return false;
        }
        cli_forest_hook(v->cf, &sp);
    }
    if (v->ca)
        city_app_frame(v->ca, &v->o, &v->fc.cam, v->width, v->height, &sp);
    uint32_t count = v->fans || patches ? 0 : (uint32_t)v->il.count;
    if (patches && !v->fans) {
        sp.patches = v->pl.data;
        sp.patch_count = (uint32_t)v->pl.count;
    }
    if (hz_renderer_draw(v->ren, &v->fc.cam, &sp, v->il.data, count, &v->ds, &v->err) != HZ_OK) {
        *render_failed = true;
        return false;
    }
    if (v->ca && v->ca->hook.failed) {
        v->err = v->ca->hook.err;
        *render_failed = true;
        return false;
    }
    if (v->cf && v->cf->hook.failed) {
        v->err = v->cf->hook.err;
        *render_failed = true;
        return false;
    }

    /* Overlays. */
    if (v->fans)
        queue_fans(v);
    uint32_t boxes_drawn = 0;
    size_t boxes_wanted = 0;
    if (v->frozen) {
        static const float culled_c[4] = {1.0f, 0.25f, 0.2f, 0.8f}, frustum_c[4] = {1.0f, 0.9f, 0.2f, 1.0f};
        hz_overlay_frustum(v->ov, &v->lod_cam, frustum_c);
        queue_boxes(v, &v->culled, culled_c, &boxes_drawn);
        boxes_wanted += v->culled.count;
    }
    if (v->boxes) {
        static const float leaf_c[4] = {0.3f, 1.0f, 0.45f, 0.7f};
        queue_boxes(v, &v->leaves, leaf_c, &boxes_drawn);
        boxes_wanted += v->leaves.count;
    }
    v->hud_w = v->hud_h = 0;
    if (v->hud)
        queue_hud(v, boxes_drawn, boxes_wanted);
    if (v->help)
        queue_help(v);
    if (v->message[0] && now < v->message_until) {
        float th;
        hz_overlay_text_size(v->message, v->hud_scale, NULL, &th);
        text(v, 8 * v->hud_scale, (float)v->height - th - 8 * v->hud_scale, C_ON, v->message);
    }
    hz_overlay_frame fr = {.cam = &v->fc.cam, .width = v->width, .height = v->height,
                           .shade_triangles = true, .wire_triangles = v->fans && v->wire};
    if (hz_overlay_draw(v->ov, &fr, &v->err) != HZ_OK) {
        *render_failed = true;
        return false;
    }

    v->frame++;
    if (v->vo.frames && v->frame >= v->vo.frames)
        go = false;
    if (shot && shot_file)
        write_shot(v, shot_file);
    if (!go && v->vo.screenshot && !write_shot(v, v->vo.screenshot))
        *render_failed = true;
    hz_window_swap(v->win);
    return go;
}

static int cmp_d(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static void print_json(view *v)
{
    double med = 0, p95 = 0, total = 0;
    if (v->frame_times_n) {
        for (size_t k = 0; k < v->frame_times_n; k++)
            total += v->frame_times[k];
        qsort(v->frame_times, v->frame_times_n, sizeof *v->frame_times, cmp_d);
        med = v->frame_times[v->frame_times_n / 2];
        size_t k95 = (size_t)ceil(0.95 * (double)v->frame_times_n);
        p95 = v->frame_times[(k95 ? k95 : 1) - 1];
    }
    const hz_camera *c = &v->fc.cam;
    char fxs[200];
    hz_fx_format(v->afx.effects, fxs, sizeof fxs);
    float az, el;
    app_fx_sun_angles(&v->afx, &az, &el);
    json_t *j = json_object();
    jx_set(j, "terrain", jx_str(v->t->source));
    jx_set(j, "heightmap_size", jx_int(v->t->hm.size));
    jx_set(j, "frames", jx_int(v->frame));
    jx_set(j, "width", jx_int(v->width));
    jx_set(j, "height", jx_int(v->height));
    jx_set(j, "fps_mean", jx_fix(total > 0 ? 1000.0 * (double)v->frame_times_n / total : 0.0, 2));
    jx_set(j, "frame_ms_median", jx_fix(med, 3));
    jx_set(j, "frame_ms_p95", jx_fix(p95, 3));
    jx_set(j, "triangles", jx_int(v->st.triangles));
    jx_set(j, "nodes_visited", jx_int(v->st.nodes_visited));
    jx_set(j, "nodes_culled", jx_int(v->st.nodes_culled));
    jx_set(j, "lod_ms", jx_fix(v->st.ms, 3));
    jx_set(j, "draw_ms", jx_fix(v->ds.draw_ms, 3));
    jx_set(j, "lod_mode", jx_str(hz_lod_mode_name(v->lod.mode)));
    jx_set(j, "pixel_error", jx_num(cli_pixel_error(&v->lod)));
    cli_near_json(j, &v->lod);
    jx_set(j, "lod_c", jx_num(v->lod.c > 0 ? v->lod.c : 25.0f));
    jx_set(j, "lod_c2", jx_num(v->lod.c2 > 0 ? v->lod.c2 : 2.5f));
    jx_set(j, "camera_mode", jx_str(hz_flycam_mode_name(&v->fc)));
    jx_set(j, "camera", json_pack("[ooooo]", jx_fix(c->pos[0], 3), jx_fix(c->pos[1], 3), jx_fix(c->pos[2], 3),
                                  jx_fix(c->yaw, 3), jx_fix(c->pitch, 3)));
    jx_set(j, "ground", jx_fix(hz_flycam_ground(&v->fc), 3));
    curv_cli_json(j, &v->o.curv);
    jx_set(j, "speed", jx_num(v->fc.speed));
    jx_set(j, "eye_height", jx_num(v->fc.eye_height));
    jx_set(j, "wireframe", jx_bool(v->wire));
    jx_set(j, "fans", jx_bool(v->fans));
    jx_set(j, "frozen", jx_bool(v->frozen));
    jx_set(j, "boxes", jx_bool(v->boxes));
    jx_set(j, "no_cull", jx_bool(v->lod.no_cull));
    jx_set(j, "screenshots", jx_int(v->shots));
    jx_set(j, "forest_trees", jx_int(v->cf ? v->cf->frame.trees : 0u));
    jx_set(j, "forest_triangles_drawn", jx_int(v->cf ? (long long)v->cf->frame.triangles_drawn : 0));
    jx_set(j, "gl", jx_str(hz_window_describe(v->win)));
    jx_set(j, "effects", jx_str(fxs));
    jx_set(j, "sun", json_pack("[oo]", jx_fix(az, 2), jx_fix(el, 2)));
    jx_set(j, "weather", jx_str(v->afx.fx.weather == HZ_WEATHER_SNOW ? "snow" : "rain"));
    jx_set(j, "billboards", jx_int(v->ds.billboards));
    jx_set(j, "particles", jx_int(v->ds.particles));
    jx_set(j, "reflections", jx_int(v->ds.reflections));
    jx_set(j, "hud", jx_str(v->hud ? (v->hud_full ? "full" : "compact") : "off"));
    jx_set(j, "hud_size", json_pack("[oo]", jx_fix(v->hud_w, 1), jx_fix(v->hud_h, 1)));
    jx_print(j, stdout);
}

static bool ends_with(const char *s, const char *suf)
{
    size_t a = strlen(s), b = strlen(suf);
    return a >= b && !strcmp(s + a - b, suf);
}

int cmd_view(int argc, char **argv)
{
    for (int i = 2; i < argc; i++)
        if (!strcmp(argv[i], "--help") || !strcmp(argv[i], "-h")) {
            usage();
            return 0;
        }
    view *v = calloc(1, sizeof *v);
    if (!v)
        return 1;
    int rc = 2;
    strlist cfg = {0};
    char **args = NULL, **rest = NULL;

    /* Config first, then the command line, so the command line wins. */
    const char *config = NULL;
    bool cmd_source = false;
    for (int i = 2; i < argc; i++) {
        if (!strcmp(argv[i], "--config") && i + 1 < argc)
            config = argv[i + 1];
        if (!strcmp(argv[i], "--dem") || !strcmp(argv[i], "--generate"))
            cmd_source = true;
    }
    if (config && view_config_read(config, &cfg, cmd_source))
        goto out;
    int nargs = 0;
    args = calloc((size_t)argc + cfg.count + 1, sizeof *args);
    rest = calloc((size_t)argc + cfg.count + 1, sizeof *rest);
    if (!args || !rest) {
        rc = 1;
        goto out;
    }
    args[nargs++] = argv[0];
    args[nargs++] = argv[1];
    for (size_t k = 0; k < cfg.count; k++)
        args[nargs++] = cfg.s[k];
    for (int i = 2; i < argc; i++)
        args[nargs++] = argv[i];
    int nrest = 0;
    rest[nrest++] = argv[0];
    rest[nrest++] = argv[1];
    if (split_view_opts(nargs, args, &v->vo, rest, &nrest))
        goto out;
    if (cli_parse(nrest, rest, 2, &v->o, "view"))
        goto out;
    if (v->o.out || v->o.dump_mesh) {
        fprintf(stderr, "horizon view: --out/--dump-mesh belong to render; use --screenshot FILE.png\n");
        goto out;
    }
    view_opts *vo = &v->vo;
    if (vo->mouse_sens <= 0)
        vo->mouse_sens = 0.15f;
    bool scripted = vo->script || vo->path || vo->frames;
    v->dt_fixed = vo->dt > 0 ? vo->dt : scripted ? 1.0f / 30.0f : 0.0f;
    if (vo->script && view_script_load(vo->script, v->dt_fixed > 0 ? v->dt_fixed : 1.0f / 30.0f, &v->sc))
        goto out;
    if (vo->path && ends_with(vo->path, ".csv")) {
        if (hz_path_load_csv(vo->path, &v->path, &v->err) != HZ_OK) {
            fprintf(stderr, "horizon view: %s\n", v->err.msg);
            goto out;
        }
        v->have_path = true;
    }
    {
        /* No output may overwrite an input (config, script, path, DEM...). */
        cli_file ins[12];
        size_t nin = cli_opts_inputs(&v->o, ins, 0, 9);
        ins[nin++] = (cli_file){config, "--config", CLI_FILE};
        ins[nin++] = (cli_file){vo->script, "--script", CLI_FILE};
        if (vo->path && ends_with(vo->path, ".csv"))
            ins[nin++] = (cli_file){vo->path, "--path", CLI_FILE};
        const cli_file outs[] = {{vo->screenshot, "--screenshot", CLI_FILE},
                                 {v->o.forest_save, "--forest-save", CLI_FILE}};
        if (cli_check_outputs("view", outs, 2, ins, nin))
            goto out;
        if (vo->shot_dir && cli_check_dir("view", "--shot-dir", vo->shot_dir)) {
            rc = 1;
            goto out;
        }
        for (size_t k = 0; k < v->sc.count; k++) {
            const cli_file ev = {v->sc.ev[k].file, "a screenshot event of --script", CLI_FILE};
            if (ev.path && cli_check_outputs("view", &ev, 1, ins, nin))
                goto out;
        }
    }

    /* Window first: it shows the loading progress. But a DEM that is not
     * there is reported before a window flashes up. */
    rc = 1;
    if (v->o.terrain.dem_path) {
        FILE *probe = fopen(v->o.terrain.dem_path, "rb");
        if (!probe) {
            fprintf(stderr, "horizon view: cannot open '%s': %s\n", v->o.terrain.dem_path, strerror(errno));
            goto out;
        }
        fclose(probe);
    }
    char title[256];
    snprintf(title, sizeof title, "horizon view");
    v->win = hz_window_create(&(hz_window_desc){.width = v->o.width, .height = v->o.height, .title = title,
                                                .no_vsync = vo->no_vsync},
                              &v->err);
    if (!v->win) {
        fprintf(stderr, "horizon view: %s\n", v->err.msg);
        goto out;
    }
    v->ov = hz_overlay_create(&v->err);
    if (!v->ov) {
        fprintf(stderr, "horizon view: %s\n", v->err.msg);
        goto out;
    }

    char what[300];
    if (v->o.terrain.dem_path)
        snprintf(what, sizeof what, "%s", v->o.terrain.dem_path);
    else
        snprintf(what, sizeof what, "%s %u seed %llu", v->o.terrain.generate == HZ_GEN_DIAMOND ? "diamond" : "perlin",
                 v->o.terrain.gen_size ? v->o.terrain.gen_size : 4097, (unsigned long long)v->o.terrain.seed);
    loading ld = {.v = v, .what = what};
    draw_loading(&ld, "reading", 0, 1);
    hz_terrain_desc td = v->o.terrain;
    td.progress = loading_progress;
    td.progress_user = &ld;
    td.max_samples = hz_gl_query_max_heightmap_samples(); /* refused before the work */
    {
        int crc = 0;
        v->ca = city_app_load(&v->o, "view", &crc);
        if (crc) {
            rc = crc;
            goto out;
        }
        td = v->o.terrain; /* the city's TIN or the scene's terrain */
        td.progress = loading_progress;
        td.progress_user = &ld;
        td.max_samples = hz_gl_query_max_heightmap_samples();
    }
    v->t = hz_terrain_create(&td, &v->err);
    if (!v->t) {
        fprintf(stderr, "horizon view: %s\n", v->err.msg);
        goto out;
    }
    cli_curvature(&v->o, v->t);
    if (v->t->note[0] && !v->o.quiet)
        fprintf(stderr, "horizon view: %s\n", v->t->note);
    if (v->t->voids_filled && !v->o.quiet)
        fprintf(stderr, "horizon view: filled %llu void samples from their neighbours\n",
                (unsigned long long)v->t->voids_filled);
    if (ld.closed) {
        rc = 0;
        goto out;
    }
    if (vo->path && !v->have_path && strcmp(vo->path, "forest") != 0) {
        if (hz_terrain_path(v->t, vo->path, &v->path, &v->err) != HZ_OK) {
            fprintf(stderr, "horizon view: %s\n", v->err.msg);
            rc = 2;
            goto out;
        }
        v->have_path = true;
    }
    draw_loading(&ld, "uploading heights to the GPU", 1, 1);

    hz_window_framebuffer_size(v->win, &v->width, &v->height);
    if (v->width == 0 || v->height == 0) {
        v->width = v->o.width;
        v->height = v->o.height;
    }
    v->ren = hz_renderer_create(&(hz_renderer_desc){.width = v->width, .height = v->height,
                                                    .to_default_framebuffer = true},
                                &v->err);
    if (!v->ren || hz_renderer_set_heightmap(v->ren, &v->t->hm, v->t->spacing, v->t->zscale, &v->err) != HZ_OK ||
        hz_renderer_set_valid(v->ren, v->t->valid, &v->err) != HZ_OK) {
        fprintf(stderr, "horizon view: %s\n", v->err.msg);
        goto out;
    }
    /* The city before the effects: its objects shade the light map. */
    if (v->ca && (city_app_place(v->ca, v->t, "view") || city_app_gpu(v->ca, "view")))
        goto out;
    draw_loading(&ld, "effects: light map, trees, water", 1, 1);
    app_fx_objects(&v->afx, v->ca);
    if (app_fx_setup(&v->afx, &v->o, v->t, v->ren, "view"))
        goto out;
    v->fx_time = v->o.time;

    if (v->o.forest_n) {
        draw_loading(&ld, "growing and ranking trees (cached after the first time)", 1, 1);
        v->cf = cli_forest_create(&v->o, v->t, v->ca ? v->ca->casters : NULL);
        if (!v->cf || cli_forest_billboards(v->cf, &v->o, v->ren))
            goto out;
    }
    if (vo->path && !v->have_path) {
        /* "forest": low across the trees (needs --forest) */
        if (!v->cf || cli_forest_path(v->cf, v->t, &v->path, &v->err) != HZ_OK) {
            fprintf(stderr, "horizon view: %s\n", v->cf ? v->err.msg : "path 'forest' needs --forest N");
            rc = 2;
            goto out;
        }
        v->have_path = true;
    }

    /* Cameras. */
    hz_camera cam = v->cf && !v->o.have_camera ? cli_forest_camera(&v->o, v->t) : cli_camera(&v->o, v->t);
    if (v->ca)
        cam = city_app_camera(v->ca, &v->o, v->t);
    cam.aspect = (float)v->width / (float)v->height;
    v->start_cam = cam;
    v->base_znear = cam.znear;
    float ext = hz_terrain_extent(v->t);
    v->fly_speed = vo->speed > 0 ? vo->speed : fmaxf(5.0f, ext / 200.0f);
    v->walk_speed = vo->walk_speed > 0 ? vo->walk_speed : 10.0f;
    hz_flycam_init(&v->fc, &(hz_flycam_desc){.start = cam, .mode = vo->free_cam ? HZ_FLYCAM_FREE : HZ_FLYCAM_VIEWER,
                                             .speed = v->fly_speed, .eye_height = vo->eye_height,
                                             .height = ground_at, .height_user = v->t});
    if (vo->walk)
        set_walk(v, true);
    v->lod = v->o.lod;
    /* Mode data built later (the L key) reports progress on the terminal:
     * the loading screen's state lives on this function's stack. */
    hz_lod_set_progress(v->t->lod, v->o.quiet ? NULL : hz_progress_stderr, NULL);
    v->lod.mode = HZ_LOD_QUADTREE;
    if (!set_lod_mode(v, v->o.lod.mode)) {
        fprintf(stderr, "horizon view: cannot prepare LOD mode %s: %s\n", hz_lod_mode_name(v->o.lod.mode),
                v->message);
        goto out;
    }
    v->wire = v->o.wireframe;
    v->fans = vo->fans;
    v->boxes = vo->boxes;
    v->hud = !vo->no_hud;
    v->hud_full = vo->hud_full;
    if (v->have_path) {
        v->path_active = true;
        hz_path_sample(&v->path, 0.0f, &v->fc.cam);
    }
    if (!v->o.quiet)
        fprintf(stderr, "horizon view: %s, %ux%u, on %s\n", v->t->source, v->t->hm.size, v->t->hm.size,
                hz_window_describe(v->win));

    v->run_t0 = v->last_ms = v->fps_t0 = hz_time_ms();
    bool failed = false;
    while (frame(v, &failed)) {
    }
    if (failed) {
        fprintf(stderr, "horizon view: %s\n", v->err.msg[0] ? v->err.msg : "rendering failed");
        goto out;
    }
    if (v->o.json)
        print_json(v);
    rc = 0;

out:
    if (v->win)
        hz_window_make_current(v->win);
    cli_forest_destroy(v->cf);
    city_app_destroy(v->ca);
    app_fx_free(&v->afx);
    hz_renderer_destroy(v->ren);
    hz_overlay_destroy(v->ov);
    hz_window_destroy(v->win);
    hz_terrain_destroy(v->t);
    free(v->il.data);
    free(v->pl.data);
    free(v->leaves.data);
    free(v->culled.data);
    free(v->frame_times);
    hz_path_free(&v->path);
    script_free(&v->sc);
    strlist_free(&cfg);
    free(args);
    free(rest);
    free(v);
    return rc;
}
