/* tests/fuzz/fuzz_common.h: what every fuzz target shares. Tandem's readers open files (their
 * messages name them), so each input is written to a file of this process's own in /dev/shm
 * (memory; /tmp where there is none) and read back through the real entry point. Log output is
 * off: a fuzzer runs millions of inputs that each fail with a message. */
#ifndef TND_FUZZ_COMMON_H
#define TND_FUZZ_COMMON_H

#include "core/core.h"

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

/* The directory of this process's inputs (made once). */
static inline const char *fuzz_dir(void)
{
    static char dir[256];
    if (!dir[0]) {
        struct stat st;
        const char *base = stat("/dev/shm", &st) == 0 ? "/dev/shm" : "/tmp";
        snprintf(dir, sizeof dir, "%s/tandem_fuzz_%ld", base, (long)getpid());
        mkdir(dir, 0700);
        tnd_log_set_level(TND_LOG_QUIET);
    }
    return dir;
}

/* Write bytes to DIR/name; the path, or NULL when it could not be written. */
static inline const char *fuzz_write(const char *name, const uint8_t *data, size_t size)
{
    static char path[2][512];
    static int k;
    char *p = path[k ^= 1];
    snprintf(p, sizeof path[0], "%s/%s", fuzz_dir(), name);
    FILE *f = fopen(p, "wb");
    if (!f)
        return NULL;
    size_t n = size ? fwrite(data, 1, size, f) : 0;
    int bad = fclose(f) != 0 || n != size;
    return bad ? NULL : p;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

#endif
