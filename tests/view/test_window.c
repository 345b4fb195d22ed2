/* The window module under Xvfb (label gpu): key names, injected input,
 * resizing, the overlay's text and boxes, two windows at once, and a window
 * next to a headless EGL context in one process (no globals of ours). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <stdlib.h>
#include <string.h>

#include "horizon/render.h"
#include "horizon/window.h"

static void test_key_names(void **state)
{
    (void)state;
    assert_int_equal(hz_key_from_name("w"), HZ_KEY_A + ('W' - 'A'));
    assert_int_equal(hz_key_from_name("W"), HZ_KEY_A + ('W' - 'A'));
    assert_int_equal(hz_key_from_name("7"), HZ_KEY_0 + 7);
    assert_int_equal(hz_key_from_name("F12"), HZ_KEY_F1 + 11);
    assert_int_equal(hz_key_from_name("f1"), HZ_KEY_F1);
    assert_int_equal(hz_key_from_name("Tab"), HZ_KEY_TAB);
    assert_int_equal(hz_key_from_name("ESC"), HZ_KEY_ESCAPE);
    assert_int_equal(hz_key_from_name("shift"), HZ_KEY_LEFT_SHIFT);
    assert_int_equal(hz_key_from_name("["), HZ_KEY_LEFT_BRACKET);
    assert_int_equal(hz_key_from_name("F13"), -1);
    assert_int_equal(hz_key_from_name("NOPE"), -1);
    assert_int_equal(hz_key_from_name(""), -1);
    for (int k = 0; k < HZ_KEY_COUNT; k++) {
        const char *n = hz_key_name(k);
        if (strcmp(n, "?"))
            assert_int_equal(hz_key_from_name(n), k); /* every named key round-trips */
    }
    assert_string_equal(hz_key_name(HZ_KEY_F1 + 4), "F5");
    assert_string_equal(hz_key_name(HZ_KEY_A), "A");
    assert_string_equal(hz_key_name(HZ_KEY_0 + 9), "9");
}

static hz_window *open_window(uint32_t w, uint32_t h)
{
    hz_err err = {0};
    hz_window *win = hz_window_create(&(hz_window_desc){.width = w, .height = h, .title = "test", .no_vsync = true},
                                      &err);
    if (!win)
        fail_msg("%s", err.msg);
    return win;
}

static void test_injected_input(void **state)
{
    (void)state;
    hz_window *w = open_window(320, 200);
    const int W = hz_key_from_name("W");
    hz_window_input in;
    hz_window_poll(w, &in);
    assert_false(hz_window_key_down(w, W));
    hz_window_inject_key(w, W, true);
    hz_window_inject_key(w, W, true); /* held: one press only */
    hz_window_inject_mouse_move(w, 12, -3);
    hz_window_inject_scroll(w, 2);
    hz_window_inject_mouse_button(w, HZ_MOUSE_LEFT, true);
    hz_window_poll(w, &in);
    assert_true(hz_window_key_down(w, W));
    assert_true(hz_window_mouse_down(w, HZ_MOUSE_LEFT));
    assert_int_equal(in.press_count, 1);
    assert_int_equal(in.presses[0], W);
    assert_true(in.mouse_dx == 12.0f && in.mouse_dy == -3.0f && in.scroll == 2.0f);
    assert_int_equal(in.fb_width, 320);
    assert_int_equal(in.fb_height, 200);
    /* Consumed: the next poll reports nothing new, W is still held. */
    hz_window_poll(w, &in);
    assert_int_equal(in.press_count, 0);
    assert_true(in.mouse_dx == 0.0f && in.scroll == 0.0f);
    assert_true(hz_window_key_down(w, W));
    hz_window_inject_key(w, W, false);
    assert_false(hz_window_key_down(w, W));
    hz_window_request_close(w);
    hz_window_poll(w, &in);
    assert_true(in.close_requested);
    hz_window_destroy(w);
}

static void test_resize(void **state)
{
    (void)state;
    hz_window *w = open_window(320, 200);
    hz_window_input in;
    hz_window_poll(w, &in);
    hz_window_set_size(w, 400, 260);
    bool resized = false;
    for (int k = 0; k < 100 && !(in.fb_width == 400 && in.fb_height == 260); k++) {
        hz_window_wait(w, 0.02);
        hz_window_poll(w, &in);
        resized = resized || in.resized;
    }
    assert_true(resized);
    assert_int_equal(in.fb_width, 400);
    assert_int_equal(in.fb_height, 260);
    hz_window_destroy(w);
}

/* Overlay in a window: white text on a cleared dark background reads back
 * as white pixels where the text is, and nothing below it; a queued box
 * without a camera is refused. */
static void test_overlay_text(void **state)
{
    (void)state;
    hz_err err = {0};
    hz_window *w = open_window(320, 200);
    hz_overlay *o = hz_overlay_create(&err);
    assert_non_null(o);
    hz_renderer *r = hz_renderer_create(&(hz_renderer_desc){.width = 320, .height = 200,
                                                            .to_default_framebuffer = true}, &err);
    assert_non_null(r);
    static const float white[4] = {1, 1, 1, 1}, half[4] = {1, 0, 0, 0.5f};
    float tw, th;
    hz_overlay_text_size("HELLO", 2, &tw, &th);
    assert_true(tw > 40 && tw < 120 && th > 10 && th < 40);
    hz_overlay_text(o, 10, 10, 2, white, "HELLO");
    hz_overlay_rect(o, 0, 150, 320, 50, half);
    hz_overlay_frame fr = {.width = 320, .height = 200, .clear = true, .clear_rgb = {0, 0, 0.2f}};
    assert_int_equal(hz_overlay_draw(o, &fr, &err), HZ_OK);
    uint8_t *rgb = malloc(320 * 200 * 3);
    assert_non_null(rgb);
    assert_int_equal(hz_renderer_read_rgb(r, rgb, &err), HZ_OK);
    int text_px = 0, bar_px = 0;
    for (int y = 0; y < 200; y++)
        for (int x = 0; x < 320; x++) {
            const uint8_t *p = rgb + 3 * (y * 320 + x);
            if (p[0] > 240 && p[1] > 240 && p[2] > 240) {
                assert_true((float)y >= 10.0f && (float)y < 10.0f + th && (float)x >= 10.0f && (float)x < 10.0f + tw);
                text_px++;
            }
            /* Red at half alpha over dark blue. */
            if (y >= 150 && p[0] > 110 && p[0] < 145 && p[2] > 15 && p[2] < 40)
                bar_px++;
        }
    assert_true(text_px > 100);
    assert_int_equal(bar_px, 320 * 50);
    free(rgb);
    vec3 box[2] = {{0, 0, 0}, {1, 1, 1}};
    hz_overlay_box(o, box, white);
    assert_int_equal(hz_overlay_draw(o, &fr, &err), HZ_ERR_VALUE);
    assert_int_equal(hz_overlay_queued_bytes(o), 0);
    hz_renderer_destroy(r);
    hz_overlay_destroy(o);
    hz_window_destroy(w);
}

/* Terrain-less renderer frame in each of two windows; destroying the first
 * leaves the second working; a third window after both are gone works
 * (GLFW re-initialised). */
static void draw_sky(hz_window *w, uint32_t width, uint32_t height)
{
    hz_err err = {0};
    hz_window_make_current(w);
    hz_renderer *r = hz_renderer_create(&(hz_renderer_desc){.width = width, .height = height,
                                                            .to_default_framebuffer = true}, &err);
    assert_non_null(r);
    hz_camera cam = {.pos = {0, 100, 0}, .pitch = 10};
    assert_int_equal(hz_renderer_draw(r, &cam, NULL, NULL, 0, NULL, &err), HZ_OK);
    uint8_t *rgb = malloc((size_t)width * height * 3);
    assert_non_null(rgb);
    assert_int_equal(hz_renderer_read_rgb(r, rgb, &err), HZ_OK);
    const uint8_t *mid = rgb + 3 * ((height / 2) * width + width / 2);
    assert_true(mid[2] > mid[0] + 30); /* sky blue */
    free(rgb);
    hz_window_swap(w);
    hz_renderer_destroy(r);
}

static void test_two_windows(void **state)
{
    (void)state;
    hz_window *a = open_window(200, 120), *b = open_window(160, 100);
    draw_sky(a, 200, 120);
    draw_sky(b, 160, 100);
    hz_window_destroy(a);
    draw_sky(b, 160, 100);
    hz_window_destroy(b);
    hz_window *c = open_window(100, 80);
    draw_sky(c, 100, 80);
    hz_window_destroy(c);
}

/* A headless EGL context and a window in one process. */
static void test_window_and_headless(void **state)
{
    (void)state;
    hz_err err = {0};
    hz_gl *gl = hz_gl_create_headless(&err);
    if (!gl)
        fail_msg("%s", err.msg);
    hz_renderer *off = hz_renderer_create(&(hz_renderer_desc){.width = 64, .height = 48}, &err);
    assert_non_null(off);
    hz_camera cam = {.pos = {0, 100, 0}, .pitch = 10};
    assert_int_equal(hz_renderer_draw(off, &cam, NULL, NULL, 0, NULL, &err), HZ_OK);
    hz_gl_destroy(gl); /* releases the EGL context; the renderer's names died with it */
    hz_renderer_destroy(off);

    hz_window *w = open_window(200, 120);
    draw_sky(w, 200, 120);
    /* And headless again while the window exists. */
    hz_window_make_current(NULL);
    gl = hz_gl_create_headless(&err);
    if (!gl)
        fail_msg("%s", err.msg);
    off = hz_renderer_create(&(hz_renderer_desc){.width = 64, .height = 48}, &err);
    assert_non_null(off);
    assert_int_equal(hz_renderer_draw(off, &cam, NULL, NULL, 0, NULL, &err), HZ_OK);
    hz_renderer_destroy(off);
    hz_gl_destroy(gl);
    draw_sky(w, 200, 120);
    hz_window_destroy(w);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_key_names),     cmocka_unit_test(test_injected_input),
        cmocka_unit_test(test_resize),        cmocka_unit_test(test_overlay_text),
        cmocka_unit_test(test_two_windows),   cmocka_unit_test(test_window_and_headless),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
