/* What both windowed views (view_cmd over a terrain in memory, view_stream
 * over a pyramid) do the same way: the keys and mouse as flycam input, the
 * timed script's events, and a screenshot of the frame. */
#ifndef HZ_VIEW_COMMON_H
#define HZ_VIEW_COMMON_H

#include <stdbool.h>
#include <stdint.h>

#include "horizon/flycam.h"
#include "horizon/render.h"
#include "horizon/window.h"
#include "view_input.h"

/* W/S, A/D, E/Q (and Page Up/Down), the arrow keys, Shift/Ctrl, and the
 * mouse while captured or a button is held, as this frame's flycam input;
 * look_yaw/look_pitch (degrees, the script's LOOK events) are added. */
hz_flycam_input view_flycam_input(hz_window *w, const hz_window_input *in, float dt, float look_yaw,
                                  float look_pitch, float mouse_sens);

/* What a frame's script events asked beyond the window's input. */
typedef struct view_script_out {
    float look_yaw, look_pitch; /* LOOK deltas, added */
    bool camera_set;            /* a CAMERA event placed fc's camera (the path stops) */
    const char *shot;           /* a SCREENSHOT event's file, or NULL */
    bool quit;
} view_script_out;

/* Applies the events of sc due at frame: keys, buttons, motion, scroll and
 * size go to the window; CAMERA moves fc's camera (the ground clamp
 * re-applied). */
void view_script_step(script *sc, uint32_t frame, hz_window *win, hz_flycam *fc, view_script_out *out);

/* Reads the w x h frame from r and writes it as a PNG at file (atomically,
 * never over an input). False with err set on failure. */
bool view_write_png(hz_renderer *r, uint32_t w, uint32_t h, const char *file, hz_err *err);

#endif
