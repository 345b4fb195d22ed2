/* Keys, scripts and screenshots shared by the two windowed views. */
#include "view_common.h"

#include <stdlib.h>

#include "horizon/safety.h"

hz_flycam_input view_flycam_input(hz_window *w, const hz_window_input *in, float dt, float look_yaw,
                                  float look_pitch, float mouse_sens)
{
    hz_flycam_input fi = {0};
#define DOWN(k) (hz_window_key_down(w, (k)) ? 1.0f : 0.0f)
#define K(c) DOWN(HZ_KEY_A + ((c) - 'A'))
    fi.forward = K('W') - K('S');
    fi.right = K('D') - K('A');
    fi.up = K('E') - K('Q') + DOWN(HZ_KEY_PAGE_UP) - DOWN(HZ_KEY_PAGE_DOWN);
    fi.fast = hz_window_key_down(w, HZ_KEY_LEFT_SHIFT) || hz_window_key_down(w, HZ_KEY_RIGHT_SHIFT);
    fi.slow = hz_window_key_down(w, HZ_KEY_LEFT_CONTROL) || hz_window_key_down(w, HZ_KEY_RIGHT_CONTROL);
    const float turn = DOWN(HZ_KEY_RIGHT) - DOWN(HZ_KEY_LEFT), tilt = DOWN(HZ_KEY_UP) - DOWN(HZ_KEY_DOWN);
#undef K
#undef DOWN
    fi.yaw_deg = 90.0f * turn * dt + look_yaw;
    fi.pitch_deg = 60.0f * tilt * dt + look_pitch;
    if (hz_window_mouse_captured(w) || hz_window_mouse_down(w, HZ_MOUSE_LEFT) ||
        hz_window_mouse_down(w, HZ_MOUSE_RIGHT)) {
        fi.yaw_deg += in->mouse_dx * mouse_sens;
        fi.pitch_deg -= in->mouse_dy * mouse_sens;
    }
    return fi;
}

void view_script_step(script *sc, uint32_t frame, hz_window *win, hz_flycam *fc, view_script_out *out)
{
    while (sc->next < sc->count && sc->ev[sc->next].frame <= frame) {
        const script_event *e = &sc->ev[sc->next++];
        switch (e->kind) {
        case EV_KEY: hz_window_inject_key(win, e->code, e->down); break;
        case EV_BUTTON: hz_window_inject_mouse_button(win, e->code, e->down); break;
        case EV_MOUSE: hz_window_inject_mouse_move(win, e->v[0], e->v[1]); break;
        case EV_LOOK:
            out->look_yaw += e->v[0];
            out->look_pitch += e->v[1];
            break;
        case EV_SCROLL: hz_window_inject_scroll(win, e->v[0]); break;
        case EV_RESIZE: hz_window_set_size(win, (uint32_t)e->v[0], (uint32_t)e->v[1]); break;
        case EV_CAMERA:
            for (int k = 0; k < 3; k++)
                fc->cam.pos[k] = e->v[k];
            fc->cam.yaw = e->v[3];
            fc->cam.pitch = e->v[4];
            hz_flycam_set_mode(fc, fc->mode); /* re-applies the ground clamp */
            out->camera_set = true;
            break;
        case EV_SCREENSHOT: out->shot = e->file; break;
        case EV_QUIT: out->quit = true; break;
        }
    }
}

bool view_write_png(hz_renderer *r, uint32_t w, uint32_t h, const char *file, hz_err *err)
{
    uint8_t *rgb = malloc((size_t)w * h * 3);
    hz_outfile of = {0};
    if (!rgb) {
        hz_err_set(err, HZ_ERR_MEMORY, "out of memory");
        return false;
    }
    const bool ok = hz_renderer_read_rgb(r, rgb, err) == HZ_OK && hz_outfile_begin(&of, file, err) == HZ_OK &&
                    hz_image_write_png(of.tmp, rgb, w, h, err) == HZ_OK && hz_outfile_commit(&of, err) == HZ_OK;
    hz_outfile_discard(&of);
    free(rgb);
    return ok;
}
