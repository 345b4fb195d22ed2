/* Reads every tile of a pyramid (a file or an http(s) URL) with N threads
 * through hz_pyramid_read_tile (fetch or disk cache, checksum, zstd, tile
 * decoding) and prints tiles/s and MB/s (compressed bytes), plus the transfer
 * figures of a URL. Measures the transport the stream's loaders use.
 * usage: pyramid_fetch FILE|URL [--threads N] [--disk-cache DIR] [--disk-cache-mb N] [--rounds R] */
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "horizon/pyramid.h"

typedef struct job {
    hz_pyramid *p;
    pthread_mutex_t lock;
    uint64_t next, total, bytes, bad;
    uint32_t (*key)[3];
} job;

static void *worker(void *arg)
{
    job *j = arg;
    for (;;) {
        pthread_mutex_lock(&j->lock);
        const uint64_t k = j->next++;
        pthread_mutex_unlock(&j->lock);
        if (k >= j->total)
            return NULL;
        const uint32_t *t = j->key[k];
        hz_pyr_tile tile;
        hz_err err = {0};
        const hz_result r = hz_pyramid_read_tile(j->p, t[0], t[1], t[2], &tile, &err);
        pthread_mutex_lock(&j->lock);
        if (r == HZ_OK)
            j->bytes += hz_pyramid_tile_bytes(j->p, t[0], t[1], t[2]);
        else
            j->bad++, fprintf(stderr, "pyramid_fetch: %s\n", err.msg);
        pthread_mutex_unlock(&j->lock);
        if (r == HZ_OK)
            hz_pyr_tile_free(&tile);
    }
}

int main(int argc, char **argv)
{
    if (argc < 2) {
        fprintf(stderr, "usage: pyramid_fetch FILE|URL [--threads N] [--disk-cache DIR] [--disk-cache-mb N] [--rounds R]\n");
        return 2;
    }
    hz_pyr_remote rem = {0};
    uint32_t threads = 8, rounds = 1;
    for (int i = 2; i + 1 < argc; i += 2) {
        if (!strcmp(argv[i], "--threads"))
            threads = (uint32_t)atoi(argv[i + 1]);
        else if (!strcmp(argv[i], "--disk-cache"))
            rem.disk_cache = argv[i + 1];
        else if (!strcmp(argv[i], "--disk-cache-mb"))
            rem.disk_cache_bytes = (uint64_t)(atof(argv[i + 1]) * 1048576.0);
        else if (!strcmp(argv[i], "--rounds"))
            rounds = (uint32_t)atoi(argv[i + 1]);
        else {
            fprintf(stderr, "pyramid_fetch: unknown option %s\n", argv[i]);
            return 2;
        }
    }
    if (threads < 1 || threads > 64 || rounds < 1) {
        fprintf(stderr, "pyramid_fetch: --threads 1..64, --rounds >= 1\n");
        return 2;
    }
    rem.connections = threads;
    for (uint32_t round = 0; round < rounds; round++) {
        const double t0 = hz_time_ms();
        hz_pyramid *p;
        hz_err err = {0};
        if (hz_pyramid_open_with(argv[1], &rem, &p, &err) != HZ_OK) {
            fprintf(stderr, "pyramid_fetch: %s\n", err.msg);
            return 1;
        }
        const hz_pyr_info *in = hz_pyramid_info(p);
        job j = {.p = p, .total = in->tiles};
        pthread_mutex_init(&j.lock, NULL);
        j.key = malloc(in->tiles * sizeof *j.key);
        uint64_t n = 0;
        for (uint32_t l = 0; l < in->levels; l++)
            for (uint32_t tz = 0; tz < hz_pyramid_tiles_per_side(p, l); tz++)
                for (uint32_t tx = 0; tx < hz_pyramid_tiles_per_side(p, l); tx++)
                    j.key[n][0] = l, j.key[n][1] = tx, j.key[n][2] = tz, n++;
        pthread_t th[64];
        for (uint32_t k = 0; k < threads; k++)
            pthread_create(&th[k], NULL, worker, &j);
        for (uint32_t k = 0; k < threads; k++)
            pthread_join(th[k], NULL);
        const double ms = hz_time_ms() - t0;
        const hz_pyr_transfer t = hz_pyramid_query_transfer(p);
        printf("{\"source\":\"%s\",\"threads\":%u,\"round\":%u,\"tiles\":%llu,\"bad\":%llu,\"ms\":%.1f,"
               "\"tiles_per_s\":%.0f,\"mb_per_s\":%.1f,\"requests\":%llu,\"http_bytes\":%llu,\"cache_hits\":%llu}\n",
               argv[1], threads, round, (unsigned long long)in->tiles, (unsigned long long)j.bad, ms,
               (double)in->tiles / ms * 1000.0, (double)j.bytes / 1e3 / ms, (unsigned long long)t.requests,
               (unsigned long long)t.bytes, (unsigned long long)t.cache_hits);
        free(j.key);
        pthread_mutex_destroy(&j.lock);
        hz_pyramid_close(p);
        if (j.bad)
            return 1;
    }
    return 0;
}
