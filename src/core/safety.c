/* Memory budget, file identity and atomic outputs (see horizon/safety.h). */
#define _DEFAULT_SOURCE /* mkstemps, realpath */
#include "horizon/safety.h"

#include <errno.h>
#include <limits.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

/* ---- memory budget ---- */

uint64_t hz_mem_budget_default(void)
{
    long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGESIZE);
    if (pages <= 0 || page <= 0)
        return (uint64_t)4 << 30;
    return (uint64_t)pages * (uint64_t)page / 2;
}

const char *hz_size_format(uint64_t bytes, char *buf, size_t cap)
{
    static const char *const unit[] = {"bytes", "KB", "MB", "GB", "TB", "PB", "EB"};
    double v = (double)bytes;
    int u = 0;
    while (v >= 1024.0 && u < 6) {
        v /= 1024.0;
        u++;
    }
    if (u == 0)
        snprintf(buf, cap, "%llu bytes", (unsigned long long)bytes);
    else
        snprintf(buf, cap, "%.1f %s", v, unit[u]);
    return buf;
}

bool hz_grow(void **p, uint32_t *cap, uint64_t need, size_t elem, uint32_t first)
{
    if (need <= *cap)
        return true;
    if (need > UINT32_MAX / 2)
        return false;
    uint64_t c = *cap ? *cap : (first ? first : 1);
    while (c < need)
        c *= 2;
    void *q = realloc(*p, (size_t)c * elem);
    if (!q)
        return false;
    *p = q;
    *cap = (uint32_t)c;
    return true;
}

hz_result hz_mem_check(uint64_t bytes, uint64_t budget, const char *what, hz_err *err)
{
    if (budget == 0)
        budget = hz_mem_budget_default();
    if (bytes <= budget)
        return HZ_OK;
    char a[32], b[32];
    return hz_err_set(err, HZ_ERR_MEMORY,
                      "%s needs %s, more than the memory budget of %s; refused before allocating "
                      "(raise it with --max-memory SIZE, e.g. --max-memory %lluG)",
                      what, hz_size_format(bytes, a, sizeof a), hz_size_format(budget, b, sizeof b),
                      (unsigned long long)((bytes >> 30) + 1));
}

bool hz_size_parse(const char *s, uint64_t min, uint64_t max, uint64_t *out)
{
    if (!s || !*s)
        return false;
    /* Plain decimal digits and one point: no sign, exponent, hex, inf or nan. */
    size_t digits = strspn(s, "0123456789."), dots = 0;
    for (size_t k = 0; k < digits; k++)
        dots += s[k] == '.';
    if (digits == 0 || dots > 1)
        return false;
    char *end;
    errno = 0;
    double v = strtod(s, &end);
    if (errno || end != s + digits || !isfinite(v) || v < 0)
        return false;
    double mul = 1;
    if (*end) {
        switch (*end) {
        case 'k': case 'K': mul = 1024.0; break;
        case 'm': case 'M': mul = 1024.0 * 1024.0; break;
        case 'g': case 'G': mul = 1024.0 * 1024.0 * 1024.0; break;
        case 't': case 'T': mul = 1024.0 * 1024.0 * 1024.0 * 1024.0; break;
        default: return false;
        }
        end++;
        if (*end == 'B' || *end == 'b')
            end++;
        if (*end)
            return false;
    }
    double bytes = v * mul;
    if (bytes < (double)min || bytes > (double)max || bytes >= 18446744073709551615.0)
        return false;
    *out = (uint64_t)bytes;
    return true;
}

/* ---- file identity ---- */

/* The resolved absolute path of p; for a file that does not exist, its
 * resolved folder plus its name. False when neither resolves. */
static bool resolve(const char *p, char *out, size_t cap)
{
    char buf[PATH_MAX];
    if (realpath(p, buf)) {
        snprintf(out, cap, "%s", buf);
        return true;
    }
    const char *slash = strrchr(p, '/');
    char dir[PATH_MAX];
    const char *name;
    if (slash) {
        size_t n = (size_t)(slash - p);
        if (n >= sizeof dir)
            return false;
        memcpy(dir, p, n);
        dir[n ? n : 1] = 0;
        if (!n)
            dir[0] = '/';
        name = slash + 1;
    } else {
        snprintf(dir, sizeof dir, ".");
        name = p;
    }
    if (!realpath(dir, buf))
        return false;
    snprintf(out, cap, "%s/%s", strcmp(buf, "/") ? buf : "", name);
    return true;
}

bool hz_same_file(const char *a, const char *b)
{
    if (!a || !b || !*a || !*b)
        return false;
    struct stat sa, sb;
    if (stat(a, &sa) == 0 && stat(b, &sb) == 0)
        return sa.st_dev == sb.st_dev && sa.st_ino == sb.st_ino;
    char ra[PATH_MAX + 256], rb[PATH_MAX + 256];
    return resolve(a, ra, sizeof ra) && resolve(b, rb, sizeof rb) && !strcmp(ra, rb);
}

/* ---- outputs written atomically ---- */

hz_result hz_outfile_begin(hz_outfile *of, const char *path, hz_err *err)
{
    memset(of, 0, sizeof *of);
    if (!path || !*path)
        return hz_err_set(err, HZ_ERR_VALUE, "no output file name given");
    if (strlen(path) >= sizeof of->path - 32)
        return hz_err_set(err, HZ_ERR_VALUE, "output file name too long: '%.64s...'", path);
    snprintf(of->path, sizeof of->path, "%s", path);
    struct stat st;
    mode_t mode = 0;
    /* A symbolic link to a file: the file it points to is the output (the
     * link stays a link), written next to it and renamed onto it. */
    struct stat lst;
    if (lstat(path, &lst) == 0 && S_ISLNK(lst.st_mode) && stat(path, &st) == 0 && S_ISREG(st.st_mode)) {
        char *real = realpath(path, NULL);
        if (!real)
            return hz_err_set(err, HZ_ERR_IO, "cannot write '%s': cannot resolve the link: %s", path, strerror(errno));
        if (strlen(real) >= sizeof of->path - 32) {
            free(real);
            return hz_err_set(err, HZ_ERR_VALUE, "output file name too long: '%.64s...'", path);
        }
        snprintf(of->path, sizeof of->path, "%s", real);
        free(real);
        path = of->path;
    }
    if (stat(path, &st) == 0) {
        if (S_ISDIR(st.st_mode))
            return hz_err_set(err, HZ_ERR_IO, "cannot write '%s': it is a directory", path);
        if (!S_ISREG(st.st_mode)) {
            /* A device or a FIFO: nothing to replace, write to it. */
            snprintf(of->tmp, sizeof of->tmp, "%s", path);
            of->direct = of->active = true;
            return HZ_OK;
        }
        mode = st.st_mode & 07777;
    }
    const char *slash = strrchr(path, '/');
    const char *name = slash ? slash + 1 : path;
    if (!*name)
        return hz_err_set(err, HZ_ERR_VALUE, "cannot write '%s': it names a folder, not a file", path);
    const char *dot = strrchr(name, '.');
    const char *ext = dot && dot != name ? dot : "";
    int dir_len = (int)(name - path);
    snprintf(of->tmp, sizeof of->tmp, "%.*s.%.*s.XXXXXX%s", dir_len, path, (int)(strlen(name) - strlen(ext)), name,
             ext);
    int fd = mkstemps(of->tmp, (int)strlen(ext));
    if (fd < 0) {
        int e = errno;
        of->tmp[0] = 0;
        return hz_err_set(err, HZ_ERR_IO, "cannot write '%s': cannot create a temporary file in its folder: %s",
                          path, strerror(e));
    }
    if (!mode) {
        mode_t um = umask(0);
        umask(um);
        mode = 0666 & ~um;
    }
    (void)fchmod(fd, mode);
    close(fd);
    of->active = true;
    return HZ_OK;
}

hz_result hz_outfile_commit(hz_outfile *of, hz_err *err)
{
    if (!of->active)
        return hz_err_set(err, HZ_ERR_VALUE, "output '%s' was not started", of->path);
    of->active = false;
    if (of->direct)
        return HZ_OK;
    if (rename(of->tmp, of->path) != 0) {
        int e = errno;
        unlink(of->tmp);
        return hz_err_set(err, HZ_ERR_IO, "cannot write '%s': rename from '%s' failed: %s", of->path, of->tmp,
                          strerror(e));
    }
    return HZ_OK;
}

void hz_outfile_discard(hz_outfile *of)
{
    if (of->active && !of->direct)
        unlink(of->tmp);
    of->active = false;
}

FILE *hz_outfile_open(hz_outfile *of, const char *path, hz_err *err)
{
    if (hz_outfile_begin(of, path, err) != HZ_OK)
        return NULL;
    FILE *f = fopen(of->tmp, "wb");
    if (!f) {
        hz_err_set(err, HZ_ERR_IO, "cannot write '%s': %s", of->tmp, strerror(errno));
        hz_outfile_discard(of);
    }
    return f;
}

hz_result hz_outfile_close(hz_outfile *of, FILE *f, hz_err *err)
{
    bool bad = ferror(f) != 0;
    int e = bad ? EIO : 0;
    if (fclose(f) != 0 && !bad) {
        bad = true;
        e = errno;
    }
    if (bad) {
        hz_outfile_discard(of);
        return hz_err_set(err, HZ_ERR_IO, "cannot write '%s': %s", of->path, strerror(e));
    }
    return hz_outfile_commit(of, err);
}
