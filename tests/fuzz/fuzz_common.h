/* tests/fuzz/fuzz_common.h: what every fuzz target shares. Tandem's readers open files (their
 * messages name them), so each input is written to a file of this process's own in /dev/shm
 * (memory; /tmp where there is none) and read back through the real entry point. Log output is
 * off: a fuzzer runs millions of inputs that each fail with a message. */
#ifndef TND_FUZZ_COMMON_H
#define TND_FUZZ_COMMON_H

#include "core/core.h"

#include <stdbool.h>
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

#ifdef TND_FUZZ_MUTATOR
/* ---- a JSON-aware mutator (glTF, mappings) ----------------------------------------------------
 * A byte-level mutator seldom turns a JSON number into an extreme one, yet counts, offsets,
 * strides and indices are where readers go wrong (a byteOffset of -1 read one byte before its
 * buffer and an hour of byte-level fuzzing did not find it). Half the mutations here are
 * structural: a number replaced by an extreme (negative, zero, fractional, 2^31, 2^32 - 1, 2^53
 * + 1, 2^64, 1e308, a denormal), a "key": value pair dropped, or one duplicated; the others are
 * libFuzzer's own. */
size_t LLVMFuzzerMutate(uint8_t *data, size_t size, size_t max_size);

static inline uint32_t fuzz_next(uint32_t *seed)
{
    *seed = *seed * 1664525u + 1013904223u;
    return *seed >> 8;
}

/* (JSON digits) */
static inline int fuzz_is_digit(uint8_t c)
{
    return c >= '0' && c <= '9';
}

static inline size_t fuzz_json_mutate(uint8_t *data, size_t size, size_t max_size,
                                      unsigned int seed)
{
    static const char *const extremes[] = {
        "-1",         "0",          "-0.5",         "0.5",         "2147483647",
        "2147483648", "-2147483649", "4294967295",  "4294967296",  "9007199254740993",
        "18446744073709551616", "1e308", "-1e308", "4.9e-324",   "1099511627776"};
    uint32_t r = seed;
    unsigned what = fuzz_next(&r) % 4;
    if (what >= 2 || size < 2)
        return LLVMFuzzerMutate(data, size, max_size);
    if (what == 0) { /* a number (after ':', ',' or '[', maybe with '-') -> an extreme */
        size_t starts[256], n = 0;
        for (size_t i = 1; i < size && n < 256; i++)
            if ((fuzz_is_digit(data[i]) || data[i] == '-') &&
                (data[i - 1] == ':' || data[i - 1] == ',' || data[i - 1] == '[' ||
                 data[i - 1] == ' '))
                starts[n++] = i;
        if (!n)
            return LLVMFuzzerMutate(data, size, max_size);
        size_t a = starts[fuzz_next(&r) % n], b = a + 1;
        while (b < size && (fuzz_is_digit(data[b]) || data[b] == '.' || data[b] == 'e' ||
                            data[b] == 'E' || data[b] == '+' || data[b] == '-'))
            b++;
        const char *x = extremes[fuzz_next(&r) % (sizeof extremes / sizeof *extremes)];
        size_t xl = strlen(x);
        if (size - (b - a) + xl > max_size)
            return LLVMFuzzerMutate(data, size, max_size);
        memmove(data + a + xl, data + b, size - b);
        memcpy(data + a, x, xl);
        return size - (b - a) + xl;
    }
    /* a "key": value pair: dropped, or written twice */
    size_t keys[256], n = 0;
    for (size_t i = 0; i + 1 < size && n < 256; i++)
        if (data[i] == '"' && (i == 0 || data[i - 1] == '{' || data[i - 1] == ',' ||
                               data[i - 1] == ' ' || data[i - 1] == '\n'))
            keys[n++] = i;
    if (!n)
        return LLVMFuzzerMutate(data, size, max_size);
    size_t a = keys[fuzz_next(&r) % n], b = a + 1;
    int depth = 0;
    bool in_str = false;
    for (; b < size; b++) { /* to the ',' or closing bracket that ends the pair */
        uint8_t c = data[b];
        if (in_str) {
            in_str = c != '"' || data[b - 1] == '\\';
            continue;
        }
        if (c == '"' && b > a + 0)
            in_str = true;
        else if (c == '{' || c == '[')
            depth++;
        else if ((c == '}' || c == ']') && depth-- == 0)
            break;
        else if (c == ',' && depth == 0)
            break;
    }
    if (b < size && data[b] == ',')
        b++; /* (the pair with its comma) */
    if (fuzz_next(&r) % 2) { /* dropped */
        memmove(data + a, data + b, size - b);
        return size - (b - a);
    }
    if (size + (b - a) > max_size)
        return LLVMFuzzerMutate(data, size, max_size);
    memmove(data + b + (b - a), data + b, size - b); /* written twice */
    memcpy(data + b, data + a, b - a);
    return size + (b - a);
}
#endif

#endif
