/* horizon camera paths: keyframes (t, x, y, z, yaw, pitch) with smooth
 * interpolation, read from CSV or built for a terrain. No GL. */
#ifndef HORIZON_PATH_H
#define HORIZON_PATH_H

#include "horizon/camera.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct hz_path_key {
    float t;              /* seconds, strictly increasing */
    float x, y, z;        /* metres, world space */
    float yaw, pitch;     /* degrees */
} hz_path_key;

typedef struct hz_path {
    hz_path_key *keys;    /* owned; free with hz_path_free */
    size_t count;
    char name[64];
} hz_path;

/* Reads "t,x,y,z,yaw,pitch" lines (an optional header line and '#' comments
 * are skipped). Fails with a message naming the line on bad numbers, fewer
 * than 2 keys or times that do not increase. */
hz_result hz_path_load_csv(const char *file, hz_path *out, hz_err *err);
hz_result hz_path_from_keys(const hz_path_key *keys, size_t count, const char *name, hz_path *out,
                            hz_err *err);
void hz_path_free(hz_path *p);
float hz_path_duration(const hz_path *p);

/* Camera at time t (clamped to the path): positions by Catmull-Rom through the
 * keys (so the camera passes exactly through every key), yaw along the
 * shortest arc, pitch linearly. Only pos/yaw/pitch of cam are written. */
void hz_path_sample(const hz_path *p, float t, hz_camera *cam);

#ifdef __cplusplus
}
#endif
#endif
