/* The disk cache of fetched ranges (see disk_cache.h). */
#include "disk_cache.h"

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <inttypes.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>
#include <xxhash.h>

#define META_MAGIC "HZDCACHE1"
#define ETAG_MAX 256u

typedef struct entry {
    char *path;
    uint64_t bytes;   /* on disk */
    int64_t stamp;    /* mtime, ns: touched on every hit */
    bool pinned;
} entry;

struct hz_dcache {
    pthread_mutex_t lock;
    char root[2048];
    char dir[2200];   /* root/<key hash> */
    entry *e;
    size_t n, cap;
    uint64_t total, limit;
    uint64_t seq;     /* temporary names */
};

static int64_t mtime_ns(const struct stat *st)
{
    return (int64_t)st->st_mtim.tv_sec * 1000000000 + st->st_mtim.tv_nsec;
}

static bool add_entry(hz_dcache *c, const char *path, uint64_t bytes, int64_t stamp, bool pinned)
{
    if (c->n == c->cap) {
        size_t cap = c->cap ? 2 * c->cap : 256;
        entry *e = realloc(c->e, cap * sizeof *e);
        if (!e)
            return false;
        c->e = e, c->cap = cap;
    }
    char *p = strdup(path);
    if (!p)
        return false;
    c->e[c->n++] = (entry){.path = p, .bytes = bytes, .stamp = stamp, .pinned = pinned};
    c->total += bytes;
    return true;
}

static bool is_range_name(const char *s)
{
    /* "<hex>-<hex>" */
    const char *d = strchr(s, '-');
    if (!d || d == s || !d[1] || strlen(s) > 40)
        return false;
    for (const char *q = s; *q; q++)
        if (q != d && !((*q >= '0' && *q <= '9') || (*q >= 'a' && *q <= 'f')))
            return false;
    return true;
}

static void scan(hz_dcache *c)
{
    DIR *r = opendir(c->root);
    if (!r)
        return;
    struct dirent *de;
    while ((de = readdir(r))) {
        if (strlen(de->d_name) != 16)
            continue;
        char sub[2300];
        snprintf(sub, sizeof sub, "%s/%s", c->root, de->d_name);
        DIR *d = opendir(sub);
        if (!d)
            continue;
        struct dirent *fe;
        while ((fe = readdir(d))) {
            if (!is_range_name(fe->d_name))
                continue;
            char path[2400];
            snprintf(path, sizeof path, "%s/%s", sub, fe->d_name);
            struct stat st;
            if (stat(path, &st) == 0 && S_ISREG(st.st_mode))
                add_entry(c, path, (uint64_t)st.st_size, mtime_ns(&st), false);
        }
        closedir(d);
    }
    closedir(r);
}

hz_dcache *hz_dcache_open(const char *dir, const char *key, uint64_t limit, hz_err *err)
{
    if (strlen(dir) >= 2000) {
        hz_err_set(err, HZ_ERR_VALUE, "--disk-cache: folder name too long");
        return NULL;
    }
    if (mkdir(dir, 0755) != 0 && errno != EEXIST) {
        hz_err_set(err, HZ_ERR_IO, "--disk-cache '%s': %s", dir, strerror(errno));
        return NULL;
    }
    struct stat st;
    if (stat(dir, &st) != 0 || !S_ISDIR(st.st_mode)) {
        hz_err_set(err, HZ_ERR_IO, "--disk-cache '%s' is not a folder", dir);
        return NULL;
    }
    hz_dcache *c = calloc(1, sizeof *c);
    if (!c) {
        hz_err_set(err, HZ_ERR_MEMORY, "out of memory");
        return NULL;
    }
    pthread_mutex_init(&c->lock, NULL);
    c->limit = limit;
    snprintf(c->root, sizeof c->root, "%s", dir);
    snprintf(c->dir, sizeof c->dir, "%s/%016" PRIx64, dir, (uint64_t)XXH64(key, strlen(key), 0));
    if (mkdir(c->dir, 0755) != 0 && errno != EEXIST) {
        hz_err_set(err, HZ_ERR_IO, "--disk-cache '%s': %s", c->dir, strerror(errno));
        hz_dcache_close(c);
        return NULL;
    }
    /* For people looking into the folder: which URL this is. */
    char name[2300];
    snprintf(name, sizeof name, "%s/url", c->dir);
    FILE *f = fopen(name, "w");
    if (f) {
        fprintf(f, "%s\n", key);
        fclose(f);
    }
    scan(c);
    return c;
}

void hz_dcache_close(hz_dcache *c)
{
    if (!c)
        return;
    for (size_t k = 0; k < c->n; k++)
        free(c->e[k].path);
    free(c->e);
    pthread_mutex_destroy(&c->lock);
    free(c);
}

static void range_path(const hz_dcache *c, uint64_t off, size_t n, char *out, size_t cap)
{
    snprintf(out, cap, "%s/%" PRIx64 "-%zx", c->dir, off, n);
}

/* Whole file into buf (exactly n bytes) or false. */
static bool read_file(const char *path, void *buf, size_t n, bool touch)
{
    int fd = open(path, O_RDONLY | O_CLOEXEC);
    if (fd < 0)
        return false;
    struct stat st;
    bool ok = fstat(fd, &st) == 0 && (uint64_t)st.st_size == n;
    uint8_t *b = buf;
    size_t got = 0;
    while (ok && got < n) {
        ssize_t r = read(fd, b + got, n - got);
        if (r < 0 && errno == EINTR)
            continue;
        if (r <= 0)
            ok = false;
        else
            got += (size_t)r;
    }
    if (ok && touch)
        futimens(fd, NULL); /* least recently used: a hit counts as a use */
    close(fd);
    return ok;
}

bool hz_dcache_get(hz_dcache *c, uint64_t off, void *buf, size_t n, const uint64_t *sum, bool *rejected)
{
    *rejected = false;
    char path[2400];
    range_path(c, off, n, path, sizeof path);
    uint8_t *tmp = malloc(n + 8);
    if (!tmp)
        return false;
    bool ok = read_file(path, tmp, n + 8, true);
    if (!ok) {
        struct stat st;
        if (stat(path, &st) == 0) { /* there but the wrong size: damaged */
            unlink(path);
            *rejected = true;
        }
        free(tmp);
        return false;
    }
    const uint64_t h = XXH64(tmp, n, 0);
    uint64_t stored = 0;
    for (int k = 7; k >= 0; k--)
        stored = (stored << 8) | tmp[n + (size_t)k];
    if (h != stored || (sum && h != *sum)) {
        unlink(path);
        *rejected = true;
        free(tmp);
        return false;
    }
    memcpy(buf, tmp, n);
    free(tmp);
    return true;
}

static bool write_atomic(hz_dcache *c, const char *path, const void *a, size_t na, const void *b, size_t nb)
{
    char tmp[2500];
    pthread_mutex_lock(&c->lock);
    const uint64_t seq = c->seq++;
    pthread_mutex_unlock(&c->lock);
    snprintf(tmp, sizeof tmp, "%s/.tmp.%ld.%" PRIu64, c->dir, (long)getpid(), seq);
    FILE *f = fopen(tmp, "wb");
    if (!f)
        return false;
    bool ok = fwrite(a, 1, na, f) == na && (nb == 0 || fwrite(b, 1, nb, f) == nb);
    ok = fclose(f) == 0 && ok;
    if (ok)
        ok = rename(tmp, path) == 0;
    if (!ok)
        unlink(tmp);
    return ok;
}

static int by_path(const void *a, const void *b)
{
    return strcmp(((const entry *)a)->path, ((const entry *)b)->path);
}

static int by_stamp(const void *a, const void *b)
{
    const entry *x = a, *y = b;
    return (x->stamp > y->stamp) - (x->stamp < y->stamp);
}

/* Under the lock. The stamps are read again from the files (another process
 * may have used them), vanished files are dropped, then the oldest go until
 * 90 % of the bound is left. */
static uint32_t evict(hz_dcache *c)
{
    qsort(c->e, c->n, sizeof *c->e, by_path);
    size_t w = 0;
    c->total = 0;
    for (size_t k = 0; k < c->n; k++) {
        struct stat st;
        if ((w > 0 && !strcmp(c->e[w - 1].path, c->e[k].path)) || stat(c->e[k].path, &st) != 0) {
            if (w > 0 && !strcmp(c->e[w - 1].path, c->e[k].path))
                c->e[w - 1].pinned |= c->e[k].pinned;
            free(c->e[k].path);
            continue;
        }
        c->e[k].bytes = (uint64_t)st.st_size;
        c->e[k].stamp = mtime_ns(&st);
        c->total += c->e[k].bytes;
        c->e[w++] = c->e[k];
    }
    c->n = w;
    qsort(c->e, c->n, sizeof *c->e, by_stamp);
    const uint64_t goal = c->limit / 10 * 9;
    uint32_t gone = 0;
    w = 0;
    for (size_t k = 0; k < c->n; k++) {
        if (c->total > goal && !c->e[k].pinned && unlink(c->e[k].path) == 0) {
            c->total -= c->e[k].bytes;
            free(c->e[k].path);
            gone++;
            continue;
        }
        c->e[w++] = c->e[k];
    }
    c->n = w;
    return gone;
}

uint32_t hz_dcache_put(hz_dcache *c, uint64_t off, const void *buf, size_t n, bool pinned)
{
    if ((uint64_t)n + 8 > c->limit && !pinned)
        return 0;
    char path[2400];
    range_path(c, off, n, path, sizeof path);
    uint8_t trail[8];
    const uint64_t h = XXH64(buf, n, 0);
    for (int k = 0; k < 8; k++)
        trail[k] = (uint8_t)(h >> (8 * k));
    if (!write_atomic(c, path, buf, n, trail, 8))
        return 0;
    uint32_t gone = 0;
    pthread_mutex_lock(&c->lock);
    add_entry(c, path, (uint64_t)n + 8, INT64_MAX, pinned);
    if (c->total > c->limit)
        gone = evict(c);
    pthread_mutex_unlock(&c->lock);
    return gone;
}

/* meta: magic, size (8), etag bytes (2), etag, header (512), XXH64 of all before. */
static size_t meta_pack(uint8_t *m, uint64_t size, const char *etag, const uint8_t header[512])
{
    const size_t el = strnlen(etag, ETAG_MAX - 1);
    size_t k = 0;
    memcpy(m, META_MAGIC, sizeof META_MAGIC - 1);
    k += sizeof META_MAGIC - 1;
    for (int b = 0; b < 8; b++)
        m[k++] = (uint8_t)(size >> (8 * b));
    m[k++] = (uint8_t)el, m[k++] = (uint8_t)(el >> 8);
    memcpy(m + k, etag, el);
    k += el;
    memcpy(m + k, header, 512);
    k += 512;
    const uint64_t h = XXH64(m, k, 0);
    for (int b = 0; b < 8; b++)
        m[k++] = (uint8_t)(h >> (8 * b));
    return k;
}

enum { META_CAP = 16 + 8 + 2 + ETAG_MAX + 512 + 8 };

bool hz_dcache_get_meta(hz_dcache *c, uint64_t *size, char *etag, size_t etag_cap, uint8_t header[512])
{
    char path[2300];
    snprintf(path, sizeof path, "%s/meta", c->dir);
    FILE *f = fopen(path, "rb");
    if (!f)
        return false;
    uint8_t m[META_CAP];
    const size_t got = fread(m, 1, sizeof m, f);
    fclose(f);
    const size_t ml = sizeof META_MAGIC - 1;
    if (got < ml + 10 + 512 + 8 || memcmp(m, META_MAGIC, ml))
        return false;
    const size_t el = m[ml + 8] | ((size_t)m[ml + 9] << 8);
    if (el >= ETAG_MAX || got != ml + 10 + el + 512 + 8)
        return false;
    uint64_t h = 0, s = 0;
    for (int b = 7; b >= 0; b--)
        h = (h << 8) | m[got - 8 + (size_t)b], s = (s << 8) | m[ml + (size_t)b];
    if (XXH64(m, got - 8, 0) != h || el >= etag_cap)
        return false;
    *size = s;
    memcpy(etag, m + ml + 10, el);
    etag[el] = 0;
    memcpy(header, m + ml + 10 + el, 512);
    return true;
}

void hz_dcache_put_meta(hz_dcache *c, uint64_t size, const char *etag, const uint8_t header[512])
{
    uint8_t now[META_CAP], old[META_CAP];
    const size_t n = meta_pack(now, size, etag, header);
    char path[2300];
    snprintf(path, sizeof path, "%s/meta", c->dir);
    FILE *f = fopen(path, "rb");
    size_t on = 0;
    if (f) {
        on = fread(old, 1, sizeof old, f);
        fclose(f);
    }
    if (on == n && !memcmp(old, now, n))
        return;
    /* A new version of the file (or a first visit): what we hold of it is stale. */
    pthread_mutex_lock(&c->lock);
    const size_t dl = strlen(c->dir);
    size_t w = 0;
    for (size_t k = 0; k < c->n; k++) {
        if (!strncmp(c->e[k].path, c->dir, dl) && c->e[k].path[dl] == '/') {
            unlink(c->e[k].path);
            c->total -= c->e[k].bytes;
            free(c->e[k].path);
            continue;
        }
        c->e[w++] = c->e[k];
    }
    c->n = w;
    pthread_mutex_unlock(&c->lock);
    write_atomic(c, path, now, n, NULL, 0);
}
