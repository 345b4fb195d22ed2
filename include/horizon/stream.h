/* Streaming a terrain pyramid (.hzp): a cache of resident tiles, a loader
 * thread that reads and decodes tiles by priority, and the cdlod selection
 * over what is resident (a node splits only where its children's tile is
 * resident; otherwise the coarser level is drawn, so there is never a hole,
 * and the restricted quadtree keeps every border crack-free). The frame
 * never waits for the disk. No GL: the renderer uploads the decoded tiles
 * (hz_renderer_set_stream / hz_renderer_stream_upload). */
#ifndef HZ_STREAM_H
#define HZ_STREAM_H

#include "horizon/camera.h"
#include "horizon/lod.h"
#include "horizon/pyramid.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct hz_stream hz_stream;

typedef struct hz_stream_desc {
    const char *path;       /* the .hzp */
    uint64_t cache_bytes;   /* tile texels held (GPU); 0 -> 256 MB; at least 8 tiles per level */
    bool synchronous;       /* tests: tiles load on the calling thread in hz_stream_update */
    uint32_t max_slots;     /* the most tiles the GPU cache can hold (hz_gl_query_max_tile_layers);
                               0 -> no limit but the 16-bit layer index */
    hz_pyr_remote remote;   /* path is an http(s) URL: how to read it (see horizon/pyramid.h) */
    uint32_t loaders;       /* loader threads; 0 -> 1 for a file, remote.connections (8) for a URL */
    float slide_seconds;    /* a tile that arrives slides in over this long (its nodes start at their
                               parent's shape and morph to their own): 0 -> 0.5 s, < 0 -> off (pops) */
} hz_stream_desc;

typedef struct hz_stream_stats {
    uint32_t requested;     /* tiles asked for this frame (new requests) */
    uint32_t loaded;        /* tiles that became resident this frame */
    uint32_t evicted;       /* this frame */
    uint32_t resident;      /* tiles in the cache now */
    uint32_t pending;       /* requests waiting or loading */
    uint32_t drawn;         /* nodes drawn (leaves of the selections) */
    uint32_t late;          /* of those, nodes drawn coarser than the LOD wanted (their distance is
                               within their split range) because a tile the split needs (their
                               children's, or one a forced split needs) was not resident */
    uint32_t failed;        /* tiles that could not be read (corrupt), drawn coarser */
    uint64_t cache_bytes;   /* texels resident */
} hz_stream_stats;

hz_stream *hz_stream_create(const hz_stream_desc *desc, hz_err *err);
void hz_stream_destroy(hz_stream *s);
const hz_pyr_info *hz_stream_info(const hz_stream *s);
/* The pyramid read (transfer figures: hz_pyramid_query_transfer). */
const hz_pyramid *hz_stream_pyramid(const hz_stream *s);
/* GPU layers the renderer must hold: one per cache slot, each (T+3)^2 RGBA16UI:
 * sample (a, b) of a tile at texel (a + 1, b + 1), a one-sample apron around it. */
uint32_t hz_stream_slots(const hz_stream *s);
uint32_t hz_stream_texels(const hz_stream *s); /* T + 3 */

/* Selects the patches for cam over the resident tiles (nearest first; each
 * patch's layer1 - 1 is its tile's slot) and asks for the tiles it lacks. */
hz_result hz_stream_select(hz_stream *s, const hz_camera *cam, const hz_lod_params *params, hz_patch_list *out,
                           hz_lod_stats *stats);

/* The clock the slide-in of arriving tiles follows, in seconds (e.g. the
 * flight's time, so a replay draws the same frames). Without a call, the
 * monotonic clock. */
void hz_stream_set_clock(hz_stream *s, double seconds);

/* Hands out a decoded tile waiting for upload: its slot and its texels
 * ((T+3)^2 x 4 uint16, see hz_stream_texels: h16, morph range, morph target low 16 bits, target
 * bit 16 | no-data << 1). Call hz_stream_uploaded after uploading it; the
 * tile is used from the next selection on. False when none waits. */
bool hz_stream_next_upload(hz_stream *s, uint32_t *slot, const uint16_t **texels);
void hz_stream_uploaded(hz_stream *s, uint32_t slot);
/* The tile a slot holds (level, column, row). */
void hz_stream_tile_key(const hz_stream *s, uint32_t slot, uint32_t *level, uint32_t *tx, uint32_t *tz);

/* Blocks until no request is waiting or loading (single images, tests). */
void hz_stream_wait(hz_stream *s);
/* Figures since the last call (per frame); resident/pending/cache are current. */
hz_stream_stats hz_stream_take_stats(hz_stream *s);
/* A repeating terrain (hz_pyr_info.wrap): moves the camera by whole periods
 * into the map's first period (coordinates stay small however far it flies).
 * Call it on the camera before selecting and drawing. Nothing otherwise. */
void hz_stream_wrap_camera(const hz_stream *s, hz_camera *cam);

/* The first read error seen (a corrupt tile), or NULL. */
const char *hz_stream_warning(hz_stream *s);

/* Height (metres) of the drawn level-0 sample nearest (x, z), from the
 * finest resident tile; NAN outside the map. */
float hz_stream_height_at(hz_stream *s, float x, float z);

#ifdef __cplusplus
}
#endif

#endif
