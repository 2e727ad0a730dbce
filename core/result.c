/* core/result.c: the result catalogue, per-thread error details, logging, time and files.
 * Entry points: tnd_fail, tnd_error_detail, tnd_log, tnd_file_read, tnd_file_write_atomic. */
#include "core/core.h"

#include <errno.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

static const char *const result_names[] = {
#define TND_X(code, msg) #code,
    TND_RESULT_LIST(TND_X)
#undef TND_X
};
static const char *const result_messages[] = {
#define TND_X(code, msg) msg,
    TND_RESULT_LIST(TND_X)
#undef TND_X
};

const char *tnd_result_name(tnd_result r)
{
    return (unsigned)r < TND_RESULT_COUNT ? result_names[r] : "TND_ERR_UNKNOWN";
}

const char *tnd_result_message(tnd_result r)
{
    return (unsigned)r < TND_RESULT_COUNT ? result_messages[r] : "unknown error";
}

/* The detail message is per thread so that worker threads can fail independently. */
static _Thread_local char error_detail[4096];

tnd_result tnd_fail(tnd_result code, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(error_detail, sizeof error_detail, fmt, ap);
    va_end(ap);
    tnd_debug("error", "%s: %s", tnd_result_name(code), error_detail);
    return code;
}

const char *tnd_error_detail(void)
{
    return error_detail;
}

void tnd_error_clear(void)
{
    error_detail[0] = '\0';
}

const char *tnd_vk_result_name(VkResult r)
{
    switch (r) {
#define C(x)                                                                                       \
    case x:                                                                                        \
        return #x;
        C(VK_SUCCESS)
        C(VK_NOT_READY)
        C(VK_TIMEOUT)
        C(VK_EVENT_SET)
        C(VK_EVENT_RESET)
        C(VK_INCOMPLETE)
        C(VK_ERROR_OUT_OF_HOST_MEMORY)
        C(VK_ERROR_OUT_OF_DEVICE_MEMORY)
        C(VK_ERROR_INITIALIZATION_FAILED)
        C(VK_ERROR_DEVICE_LOST)
        C(VK_ERROR_MEMORY_MAP_FAILED)
        C(VK_ERROR_LAYER_NOT_PRESENT)
        C(VK_ERROR_EXTENSION_NOT_PRESENT)
        C(VK_ERROR_FEATURE_NOT_PRESENT)
        C(VK_ERROR_INCOMPATIBLE_DRIVER)
        C(VK_ERROR_TOO_MANY_OBJECTS)
        C(VK_ERROR_FORMAT_NOT_SUPPORTED)
        C(VK_ERROR_FRAGMENTED_POOL)
        C(VK_ERROR_UNKNOWN)
        C(VK_ERROR_OUT_OF_POOL_MEMORY)
        C(VK_ERROR_INVALID_EXTERNAL_HANDLE)
        C(VK_ERROR_FRAGMENTATION)
        C(VK_ERROR_INVALID_OPAQUE_CAPTURE_ADDRESS)
        C(VK_PIPELINE_COMPILE_REQUIRED)
        C(VK_THREAD_IDLE_KHR)
        C(VK_THREAD_DONE_KHR)
        C(VK_OPERATION_DEFERRED_KHR)
        C(VK_OPERATION_NOT_DEFERRED_KHR)
#undef C
    default:
        return "VK_RESULT_UNKNOWN";
    }
}

static _Atomic bool device_lost;

bool tnd_vk_device_lost(void)
{
    return device_lost;
}

tnd_result tnd_fail_vk(const char *file, int line, const char *call, VkResult r)
{
    /* Keep the call short: up to its first parenthesis, which names the function. */
    int n = (int)strcspn(call, "(");
    const char *base = strrchr(file, '/');
    if (r == VK_ERROR_DEVICE_LOST) /* (what the user needs: it is not Tandem's input) */
        device_lost = true;
    if (r == VK_ERROR_DEVICE_LOST)
        return tnd_fail(TND_ERR_VULKAN,
                        "vulkan: the device was lost (%s:%d: %.*s -> VK_ERROR_DEVICE_LOST): a "
                        "driver reset, a GPU fault or work that ran past the driver's time "
                        "limit; the work in flight is gone",
                        base ? base + 1 : file, line, n, call);
    return tnd_fail(TND_ERR_VULKAN, "%s:%d: %.*s -> %s", base ? base + 1 : file, line, n, call,
                    tnd_vk_result_name(r));
}

/* The one process-wide setting: chosen once by app/ before any work starts. */
static tnd_log_level log_level = TND_LOG_INFO;

void tnd_log_set_level(tnd_log_level level)
{
    log_level = level;
}

tnd_log_level tnd_log_get_level(void)
{
    return log_level;
}

void tnd_log(tnd_log_level level, const char *module, const char *fmt, ...)
{
    /* INFO (0) is the default level; DEBUG is more verbose than INFO. */
    static const int rank[] = {[TND_LOG_DEBUG] = 0,
                               [TND_LOG_INFO] = 1,
                               [TND_LOG_WARN] = 2,
                               [TND_LOG_ERROR] = 3,
                               [TND_LOG_QUIET] = 4};
    if (rank[level] < rank[log_level] || level == TND_LOG_QUIET)
        return;
    char buf[2048];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(buf, sizeof buf, fmt, ap);
    va_end(ap);
    const char *tag = level == TND_LOG_WARN ? "warning: " : level == TND_LOG_ERROR ? "error: " : "";
    fprintf(stderr, "tandem: %s: %s%s\n", module, tag, buf);
}

double tnd_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

tnd_result tnd_file_read(const char *path, void **data, size_t *size)
{
    *data = NULL;
    *size = 0;
    FILE *f = fopen(path, "rb");
    if (!f)
        return tnd_fail(TND_ERR_IO, "%s: cannot open: %s", path, strerror(errno));
    char *buf = NULL;
    size_t cap = 0, len = 0;
    for (;;) {
        if (len + 65536 + 1 > cap) {
            size_t ncap = cap ? cap * 2 : 65536 * 2;
            char *nb = realloc(buf, ncap);
            if (!nb) {
                free(buf);
                fclose(f);
                return tnd_fail(TND_ERR_OUT_OF_MEMORY, "%s: out of memory reading", path);
            }
            buf = nb;
            cap = ncap;
        }
        size_t got = fread(buf + len, 1, cap - len - 1, f);
        len += got;
        if (got == 0)
            break;
    }
    int err = ferror(f);
    fclose(f);
    if (err) {
        free(buf);
        return tnd_fail(TND_ERR_IO, "%s: read error", path);
    }
    buf[len] = '\0';
    *data = buf;
    *size = len;
    return TND_OK;
}

tnd_result tnd_file_write_atomic(const char *path, const void *data, size_t size)
{
    char tmp[4096];
    if (snprintf(tmp, sizeof tmp, "%s.tmp.%ld", path, (long)getpid()) >= (int)sizeof tmp)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "%s: path too long", path);
    FILE *f = fopen(tmp, "wb");
    if (!f)
        return tnd_fail(TND_ERR_IO, "%s: cannot create: %s", tmp, strerror(errno));
    size_t put = fwrite(data, 1, size, f);
    int err = (put != size) | (fflush(f) != 0);
    err |= fclose(f) != 0;
    if (err) {
        remove(tmp);
        return tnd_fail(TND_ERR_IO, "%s: write failed: %s", path, strerror(errno));
    }
    if (rename(tmp, path) != 0) {
        int e = errno;
        remove(tmp);
        return tnd_fail(TND_ERR_IO, "%s: cannot rename into place: %s", path, strerror(e));
    }
    return TND_OK;
}

tnd_result tnd_mkdirs(const char *path)
{
    char buf[4096];
    size_t n = strlen(path);
    if (n == 0 || n >= sizeof buf)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "mkdir: bad path '%s'", path);
    memcpy(buf, path, n + 1);
    for (size_t i = 1; i <= n; i++) {
        if (buf[i] == '/' || buf[i] == '\0') {
            char c = buf[i];
            buf[i] = '\0';
            if (mkdir(buf, 0777) != 0 && errno != EEXIST)
                return tnd_fail(TND_ERR_IO, "%s: cannot create directory: %s", buf,
                                strerror(errno));
            buf[i] = c;
        }
    }
    struct stat st;
    if (stat(path, &st) != 0 || !S_ISDIR(st.st_mode))
        return tnd_fail(TND_ERR_IO, "%s: not a directory", path);
    return TND_OK;
}
