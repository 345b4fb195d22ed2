/* horizon safety: the memory budget for allocations sized from untrusted
 * input, file identity (an output must never be one of the inputs) and
 * outputs written to a temporary file in the same folder, renamed into place
 * when complete. No GL, no globals. */
#ifndef HORIZON_SAFETY_H
#define HORIZON_SAFETY_H

#include <stdio.h>

#include "horizon/core.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ---- memory budget ---- */

/* The default budget: half of the physical RAM (sysconf), or 4 GiB when that
 * is unknown. Bytes. */
uint64_t hz_mem_budget_default(void);

/* budget 0 -> hz_mem_budget_default(). HZ_OK when bytes <= budget, else
 * HZ_ERR_MEMORY with a message naming what, both sizes and the option that
 * raises the budget ("--max-memory"). */
hz_result hz_mem_check(uint64_t bytes, uint64_t budget, const char *what, hz_err *err);

/* Parses a size: a number of bytes with an optional K, M, G or T suffix
 * (powers of 1024; "1.5G"), the whole string. False on anything else or on
 * sizes outside [min, max] bytes. */
bool hz_size_parse(const char *s, uint64_t min, uint64_t max, uint64_t *out);
/* Formats bytes as "17.2 GB" (powers of 1024, GB = GiB) into buf. */
const char *hz_size_format(uint64_t bytes, char *buf, size_t cap);

/* Grows the array *p of *cap elements of elem bytes to hold at least need,
 * doubling from first elements. False, with *p and *cap unchanged, when need
 * exceeds UINT32_MAX / 2 (counts stay 32-bit) or realloc fails. */
bool hz_grow(void **p, uint32_t *cap, uint64_t need, size_t elem, uint32_t first);

/* ---- file identity ---- */

/* True when a and b name the same file: both exist and have the same device
 * and inode, or their resolved paths (symlinks and "..", of the folder for a
 * file that does not exist yet) are equal. */
bool hz_same_file(const char *a, const char *b);

/* ---- outputs written atomically ---- */

typedef struct hz_outfile {
    char path[4096];  /* where the file goes */
    char tmp[4096];   /* what to write meanwhile (same folder); == path when direct */
    bool direct;      /* path is not a regular file (/dev/stdout, a FIFO): written in place */
    bool active;
} hz_outfile;

/* Creates a fresh temporary file next to path (".NAME.XXXXXX.EXT", keeping
 * the extension) for a writer that takes a file name: write of->tmp, then
 * hz_outfile_commit. An existing non-regular path (a device, a FIFO) is
 * written directly. Fails when the folder is not writable or path is a
 * directory. */
hz_result hz_outfile_begin(hz_outfile *of, const char *path, hz_err *err);
/* Renames the temporary file onto path (the old file, if any, is replaced in
 * one step). On failure the temporary file is removed. */
hz_result hz_outfile_commit(hz_outfile *of, hz_err *err);
/* Removes the temporary file (the old file at path is untouched). Safe to
 * call twice or after commit. */
void hz_outfile_discard(hz_outfile *of);

/* begin + fopen(of->tmp, "wb"). NULL after filling err. */
FILE *hz_outfile_open(hz_outfile *of, const char *path, hz_err *err);
/* fclose(f) (checking write errors), then commit; on any error discards. */
hz_result hz_outfile_close(hz_outfile *of, FILE *f, hz_err *err);

#ifdef __cplusplus
}
#endif
#endif
