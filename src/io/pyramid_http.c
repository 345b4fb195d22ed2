/* Reading a pyramid over http(s) with libcurl (see pyramid_src.h and
 * docs/serving.md): one byte range per read on the single .hzp file.
 *
 * - Keep-alive: a pool of easy handles, each taken by one read at a time and
 *   given back, so every loader thread reuses a warm connection; the handles
 *   share one connection cache, DNS and TLS sessions (a curl share handle).
 * - Every response is checked: 206 with the Content-Range asked for and
 *   exactly the bytes asked for, and the tile's XXH64 when the caller gives
 *   it. A server that ignores ranges (200) is refused at once rather than
 *   downloading the whole file.
 * - Failures that may pass (a connection refused, dropped or timed out, 5xx,
 *   408, 429, a short or corrupt body) are retried with exponential backoff
 *   (100 ms doubling, with jitter, at most 3.2 s); 4xx are not. A read that
 *   still fails is an error the stream turns into "drawn coarser + warning".
 * - Optional disk cache (disk_cache.c): hits never touch the network; a
 *   server that does not answer at open is read from the cache alone. */
#include "disk_cache.h"
#include "pyramid_src.h"

#include <curl/curl.h>
#include <inttypes.h>
#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <time.h>
#include <xxhash.h>

#define MAX_HANDLES 64u
#define HDR_BYTES 512u
#define DOWN_MS 5000.0 /* after a read whose every attempt found no server */

typedef struct http_src {
    hz_pyr_src base;
    char *url;
    hz_pyr_remote opt;
    CURLSH *share;
    pthread_mutex_t share_lock[CURL_LOCK_DATA_LAST];
    pthread_mutex_t lock; /* handles, figures, jitter */
    CURL *idle[MAX_HANDLES];
    uint32_t nidle;
    uint64_t jitter;
    hz_pyr_transfer t;
    hz_dcache *cache;
    double down_until;    /* hz_time_ms: the server did not answer; reads fail at once until then */
    uint8_t header[HDR_BYTES];
    bool have_header;
} http_src;

bool hz_pyr_is_url(const char *path)
{
    return !strncasecmp(path, "http://", 7) || !strncasecmp(path, "https://", 8);
}

/* ---- curl plumbing ---- */

static pthread_once_t curl_once = PTHREAD_ONCE_INIT;
static CURLcode curl_init_rc = CURLE_FAILED_INIT;

static void curl_init(void)
{
    curl_init_rc = curl_global_init(CURL_GLOBAL_DEFAULT);
}

static void share_lock(CURL *c, curl_lock_data d, curl_lock_access a, void *user)
{
    (void)c, (void)a;
    pthread_mutex_lock(&((http_src *)user)->share_lock[d]);
}

static void share_unlock(CURL *c, curl_lock_data d, void *user)
{
    (void)c;
    pthread_mutex_unlock(&((http_src *)user)->share_lock[d]);
}

/* One transfer's state, filled by the callbacks. */
typedef struct xfer {
    uint8_t *buf;
    size_t cap, got;
    bool overflow;
    long status;          /* of the last response (redirects reset it) */
    bool have_range;
    uint64_t r0, r1, total; /* Content-Range: bytes r0-r1/total (total 0 if "*") */
    char etag[200];
} xfer;

static size_t on_body(char *p, size_t size, size_t nmemb, void *user)
{
    xfer *x = user;
    const size_t n = size * nmemb;
    if (n > x->cap - x->got) {
        x->overflow = true; /* more than asked for: never buffer a whole file */
        return 0;
    }
    memcpy(x->buf + x->got, p, n);
    x->got += n;
    return n;
}

static size_t on_header(char *p, size_t size, size_t nmemb, void *user)
{
    xfer *x = user;
    const size_t n = size * nmemb;
    char line[512];
    const size_t l = n < sizeof line - 1 ? n : sizeof line - 1;
    memcpy(line, p, l);
    line[l] = 0;
    if (!strncmp(line, "HTTP/", 5)) { /* a new response (after a redirect or 100) */
        const char *sp = strchr(line, ' ');
        x->status = sp ? strtol(sp + 1, NULL, 10) : 0;
        x->have_range = false;
        x->etag[0] = 0;
        x->got = 0;
        x->overflow = false;
    } else if (!strncasecmp(line, "content-range:", 14)) {
        unsigned long long a, b, t = 0;
        char star;
        if (sscanf(line + 14, " bytes %llu-%llu/%llu", &a, &b, &t) == 3 ||
            sscanf(line + 14, " bytes %llu-%llu/%c", &a, &b, &star) == 3) {
            x->have_range = true;
            x->r0 = a, x->r1 = b, x->total = t;
        }
    } else if (!strncasecmp(line, "etag:", 5)) {
        const char *v = line + 5;
        while (*v == ' ' || *v == '\t')
            v++;
        const size_t el = strcspn(v, "\r\n");
        if (el < sizeof x->etag) {
            memcpy(x->etag, v, el);
            x->etag[el] = 0;
        }
    }
    return n;
}

static CURL *handle_take(http_src *h)
{
    CURL *c = NULL;
    pthread_mutex_lock(&h->lock);
    if (h->nidle > 0)
        c = h->idle[--h->nidle];
    pthread_mutex_unlock(&h->lock);
    if (c)
        return c;
    c = curl_easy_init();
    if (!c)
        return NULL;
    curl_easy_setopt(c, CURLOPT_URL, h->url);
    curl_easy_setopt(c, CURLOPT_SHARE, h->share);
    curl_easy_setopt(c, CURLOPT_NOSIGNAL, 1L); /* threads: no SIGALRM for timeouts */
    curl_easy_setopt(c, CURLOPT_PROTOCOLS_STR, "http,https");
    curl_easy_setopt(c, CURLOPT_REDIR_PROTOCOLS_STR, "http,https");
    curl_easy_setopt(c, CURLOPT_FOLLOWLOCATION, 1L); /* presigned / regional redirects of object stores */
    curl_easy_setopt(c, CURLOPT_MAXREDIRS, 5L);
    curl_easy_setopt(c, CURLOPT_CONNECTTIMEOUT_MS, (long)h->opt.timeout_ms);
    curl_easy_setopt(c, CURLOPT_TCP_KEEPALIVE, 1L);
    curl_easy_setopt(c, CURLOPT_USERAGENT, "horizon-pyramid/1 (libcurl)");
    curl_easy_setopt(c, CURLOPT_WRITEFUNCTION, on_body);
    curl_easy_setopt(c, CURLOPT_HEADERFUNCTION, on_header);
    return c;
}

static void handle_give(http_src *h, CURL *c)
{
    pthread_mutex_lock(&h->lock);
    if (h->nidle < MAX_HANDLES) {
        h->idle[h->nidle++] = c;
        c = NULL;
    }
    pthread_mutex_unlock(&h->lock);
    if (c)
        curl_easy_cleanup(c);
}

enum { FETCH_OK, FETCH_RETRY, FETCH_FATAL };

/* One attempt at [off, off + n). why receives the reason of a failure. */
static int fetch_once(http_src *h, CURL *c, void *buf, size_t n, uint64_t off, const uint64_t *sum, xfer *x,
                      char *why, size_t why_cap)
{
    char range[64];
    snprintf(range, sizeof range, "%" PRIu64 "-%" PRIu64, off, off + n - 1);
    char errbuf[CURL_ERROR_SIZE] = "";
    *x = (xfer){.buf = buf, .cap = n};
    curl_easy_setopt(c, CURLOPT_RANGE, range);
    /* the timeout, plus time for the body at 100 kB/s (the index of a planet is tens of MB) */
    curl_easy_setopt(c, CURLOPT_TIMEOUT_MS, (long)(h->opt.timeout_ms + n / 100));
    curl_easy_setopt(c, CURLOPT_WRITEDATA, x);
    curl_easy_setopt(c, CURLOPT_HEADERDATA, x);
    curl_easy_setopt(c, CURLOPT_ERRORBUFFER, errbuf);
    const CURLcode rc = curl_easy_perform(c);
    curl_easy_setopt(c, CURLOPT_ERRORBUFFER, NULL);
    pthread_mutex_lock(&h->lock);
    h->t.requests++;
    h->t.bytes += x->got;
    pthread_mutex_unlock(&h->lock);
    const long st = x->status;
    if (st >= 400) {
        snprintf(why, why_cap, "HTTP %ld", st);
        return st >= 500 || st == 408 || st == 429 ? FETCH_RETRY : FETCH_FATAL;
    }
    if (rc != CURLE_OK && !(rc == CURLE_WRITE_ERROR && x->overflow && st == 200)) {
        snprintf(why, why_cap, "%s", errbuf[0] ? errbuf : curl_easy_strerror(rc));
        return FETCH_RETRY; /* refused, reset, timed out, dropped mid-body: may pass */
    }
    if (st == 200) {
        snprintf(why, why_cap, "the server does not answer range requests (HTTP 200 instead of 206)");
        return FETCH_FATAL;
    }
    if (st != 206) {
        snprintf(why, why_cap, "unexpected HTTP %ld", st);
        return FETCH_FATAL;
    }
    if (!x->have_range || x->r0 != off || x->r1 != off + n - 1 || x->got != n || x->overflow) {
        snprintf(why, why_cap, "got bytes %" PRIu64 "-%" PRIu64 " (%zu bytes), asked %s", x->r0, x->r1, x->got, range);
        return FETCH_RETRY;
    }
    if (sum && XXH64(buf, n, 0) != *sum) {
        snprintf(why, why_cap, "the bytes received fail their checksum (corrupt)");
        return FETCH_RETRY;
    }
    return FETCH_OK;
}

static void sleep_ms(double ms)
{
    struct timespec ts = {.tv_sec = (time_t)(ms / 1000.0), .tv_nsec = (long)(fmod(ms, 1000.0) * 1e6)};
    while (nanosleep(&ts, &ts) != 0)
        ;
}

/* Attempts with backoff. etag (may be NULL) receives the server's. */
static hz_result fetch(http_src *h, void *buf, size_t n, uint64_t off, const uint64_t *sum, uint64_t *total,
                       char *etag, size_t etag_cap, hz_err *err)
{
    /* A server that answered nothing to a whole read's attempts (refused,
     * unreachable, timed out) is not asked again for DOWN_MS: otherwise
     * every missing tile would wait for all its timeouts in turn. */
    pthread_mutex_lock(&h->lock);
    const double down = h->down_until - hz_time_ms();
    if (down > 0)
        h->t.failures++;
    pthread_mutex_unlock(&h->lock);
    if (down > 0)
        return hz_err_set(err, HZ_ERR_IO, "bytes %" PRIu64 "+%zu: the server did not answer; asking again in %.1f s",
                          off, n, down / 1000.0);
    CURL *c = handle_take(h);
    if (!c)
        return hz_err_set(err, HZ_ERR_MEMORY, "libcurl: cannot create a handle");
    char why[400] = "";
    xfer x;
    uint32_t attempt = 0;
    int res;
    for (;;) {
        res = fetch_once(h, c, buf, n, off, sum, &x, why, sizeof why);
        if (res != FETCH_RETRY || attempt >= h->opt.retries)
            break;
        /* 100 ms, 200, 400 ... 3.2 s, each times 0.5 .. 1 so that loaders
         * failing together do not come back together. */
        pthread_mutex_lock(&h->lock);
        h->t.retries++;
        h->jitter = h->jitter * 6364136223846793005ULL + 1442695040888963407ULL;
        const double j = 0.5 + 0.5 * (double)(h->jitter >> 11) / 9007199254740992.0;
        pthread_mutex_unlock(&h->lock);
        const uint32_t e = attempt < 5 ? attempt : 5;
        sleep_ms(100.0 * (double)(1u << e) * j);
        attempt++;
    }
    handle_give(h, c);
    if (res != FETCH_OK) {
        pthread_mutex_lock(&h->lock);
        h->t.failures++;
        if (x.status == 0) /* no HTTP answer at all */
            h->down_until = hz_time_ms() + DOWN_MS;
        pthread_mutex_unlock(&h->lock);
        return hz_err_set(err, sum && strstr(why, "checksum") ? HZ_ERR_FORMAT : HZ_ERR_IO,
                          "bytes %" PRIu64 "+%zu: %s (%u attempt%s)", off, n, why, attempt + 1, attempt ? "s" : "");
    }
    if (total)
        *total = x.total;
    if (etag)
        snprintf(etag, etag_cap, "%s", x.etag);
    return HZ_OK;
}

/* ---- the source ---- */

static hz_result http_read(hz_pyr_src *src, void *buf, size_t n, uint64_t off, const uint64_t *sum, hz_err *err)
{
    http_src *h = (http_src *)src;
    if (n == 0)
        return HZ_OK;
    if (off > src->size || n > src->size - off)
        return hz_err_set(err, HZ_ERR_IO, "bytes %" PRIu64 "+%zu lie past the end of the file", off, n);
    if (off == 0 && n <= HDR_BYTES && h->have_header) {
        memcpy(buf, h->header, n);
        return HZ_OK;
    }
    if (h->cache) {
        bool rejected;
        const bool hit = hz_dcache_get(h->cache, off, buf, n, sum, &rejected);
        pthread_mutex_lock(&h->lock);
        h->t.cache_hits += hit;
        h->t.cache_bytes += hit ? n : 0;
        h->t.cache_rejected += rejected;
        pthread_mutex_unlock(&h->lock);
        if (hit)
            return HZ_OK;
    }
    hz_result r = fetch(h, buf, n, off, sum, NULL, NULL, 0, err);
    if (r == HZ_OK && h->cache) {
        const uint32_t gone = hz_dcache_put(h->cache, off, buf, n, sum == NULL);
        pthread_mutex_lock(&h->lock);
        h->t.cache_evicted += gone;
        pthread_mutex_unlock(&h->lock);
    }
    return r;
}

static hz_pyr_transfer http_transfer(const hz_pyr_src *src)
{
    http_src *h = (http_src *)src;
    pthread_mutex_lock(&h->lock);
    hz_pyr_transfer t = h->t;
    pthread_mutex_unlock(&h->lock);
    return t;
}

static void http_close(hz_pyr_src *src)
{
    http_src *h = (http_src *)src;
    for (uint32_t k = 0; k < h->nidle; k++)
        curl_easy_cleanup(h->idle[k]);
    if (h->share)
        curl_share_cleanup(h->share);
    for (int k = 0; k < CURL_LOCK_DATA_LAST; k++)
        pthread_mutex_destroy(&h->share_lock[k]);
    pthread_mutex_destroy(&h->lock);
    hz_dcache_close(h->cache);
    free(h->url);
    free(h);
}

static const hz_pyr_src_vt HTTP_VT = {.read = http_read, .transfer = http_transfer, .close = http_close};

hz_result hz_pyr_http_open(const char *url, const hz_pyr_remote *opt, hz_pyr_src **out, hz_err *err)
{
    *out = NULL;
    pthread_once(&curl_once, curl_init);
    if (curl_init_rc != CURLE_OK)
        return hz_err_set(err, HZ_ERR_IO, "libcurl: %s", curl_easy_strerror(curl_init_rc));
    http_src *h = calloc(1, sizeof *h);
    if (!h)
        return hz_err_set(err, HZ_ERR_MEMORY, "out of memory");
    h->base = (hz_pyr_src){.vt = &HTTP_VT, .remote = true};
    h->opt = opt ? *opt : (hz_pyr_remote){0};
    h->opt.disk_cache = NULL; /* not retained */
    if (!h->opt.timeout_ms)
        h->opt.timeout_ms = 10000;
    if (!h->opt.retries)
        h->opt.retries = 4;
    if (!h->opt.connections)
        h->opt.connections = 8;
    h->jitter = XXH64(url, strlen(url), (uint64_t)time(NULL));
    for (int k = 0; k < CURL_LOCK_DATA_LAST; k++)
        pthread_mutex_init(&h->share_lock[k], NULL);
    pthread_mutex_init(&h->lock, NULL);
    h->url = strdup(url);
    h->share = curl_share_init();
    if (!h->url || !h->share) {
        http_close(&h->base);
        return hz_err_set(err, HZ_ERR_MEMORY, "out of memory");
    }
    curl_share_setopt(h->share, CURLSHOPT_LOCKFUNC, share_lock);
    curl_share_setopt(h->share, CURLSHOPT_UNLOCKFUNC, share_unlock);
    curl_share_setopt(h->share, CURLSHOPT_USERDATA, h);
    curl_share_setopt(h->share, CURLSHOPT_SHARE, CURL_LOCK_DATA_CONNECT);
    curl_share_setopt(h->share, CURLSHOPT_SHARE, CURL_LOCK_DATA_DNS);
    curl_share_setopt(h->share, CURLSHOPT_SHARE, CURL_LOCK_DATA_SSL_SESSION);
    if (opt && opt->disk_cache) {
        const uint64_t limit = opt->disk_cache_bytes ? opt->disk_cache_bytes : (1ull << 30);
        h->cache = hz_dcache_open(opt->disk_cache, url, limit, err);
        if (!h->cache) {
            http_close(&h->base);
            return err ? err->code : HZ_ERR_IO;
        }
    }
    /* The header tells the file's size (Content-Range) and, with the ETag,
     * its version: a cache holding another version is emptied. */
    uint64_t total = 0;
    char etag[200] = "";
    hz_err fe = {0};
    hz_result r = fetch(h, h->header, HDR_BYTES, 0, NULL, &total, etag, sizeof etag, &fe);
    if (r == HZ_OK && total == 0)
        r = hz_err_set(&fe, HZ_ERR_IO, "the server does not say the file's size (Content-Range: bytes 0-511/*)");
    if (r == HZ_OK) {
        h->base.size = total;
        h->have_header = true;
        if (h->cache)
            hz_dcache_put_meta(h->cache, total, etag, h->header);
    } else if (fe.code == HZ_ERR_IO && h->cache &&
               hz_dcache_get_meta(h->cache, &total, etag, sizeof etag, h->header)) {
        /* Offline: the server did not answer; fly on what the cache holds
         * (a tile it lacks is one more read error, drawn coarser). */
        h->base.size = total;
        h->have_header = true;
        h->t.offline = true;
        h->t.failures--; /* the header's fetch: no tile drawn coarser for it */
    } else {
        http_close(&h->base);
        return hz_err_set(err, fe.code ? fe.code : HZ_ERR_IO, "cannot read '%s': %s", url, fe.msg);
    }
    *out = &h->base;
    return HZ_OK;
}
