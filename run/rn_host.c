/* run/rn_host.c: what every run shares: how it speaks through its host (lines, progress,
 * interrupts), one writer per output directory, scenes with their options, the bounces word,
 * the frame lists of run directories and the timings' members.
 * Entry points: rn_say, rn_warn, rn_interrupted, rn_host_quiet, rn_progress_*, rn_signal_name,
 * rn_lock_dir, rn_unlock_dir, rn_remove_flat_dir, rn_scene_load, rn_bounces_parse,
 * rn_bounces_split, rn_list_frames, rn_median, rn_timings_members. */
#include "run/rn_internal.h"

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* ---- the host ---------------------------------------------------------------------------------- */
static void say(void (*fn)(void *, const char *), void *user, const char *fmt, va_list ap)
{
    char line[4096];
    vsnprintf(line, sizeof line, fmt, ap);
    fn(user, line);
}

void rn_say(const rn_host *h, const char *fmt, ...)
{
    if (!h || h->quiet || !h->message)
        return;
    va_list ap;
    va_start(ap, fmt);
    say(h->message, h->user, fmt, ap);
    va_end(ap);
}

void rn_warn(const rn_host *h, const char *fmt, ...)
{
    if (!h || !h->warning)
        return;
    va_list ap;
    va_start(ap, fmt);
    say(h->warning, h->user, fmt, ap);
    va_end(ap);
}

int rn_interrupted(const rn_host *h)
{
    return h && h->interrupted ? h->interrupted(h->user) : 0;
}

rn_host rn_host_quiet(const rn_host *h)
{
    rn_host q = h ? *h : (rn_host){0};
    q.quiet = true;
    return q;
}

void rn_progress_begin(rn_progress *p, const rn_host *h, const char *label, uint64_t total)
{
    *p = (rn_progress){.host = h && !h->quiet && h->progress ? h : NULL, .label = label,
                       .total = total};
    if (p->host)
        p->host->progress(p->host->user, RN_PROGRESS_BEGIN, label, 0, total);
}

void rn_progress_step(rn_progress *p, uint64_t done)
{
    p->done = done;
    if (p->host)
        p->host->progress(p->host->user, RN_PROGRESS_STEP, p->label, done, p->total);
}

void rn_progress_end(rn_progress *p)
{
    if (p->host)
        p->host->progress(p->host->user, RN_PROGRESS_END, p->label, p->total, p->total);
    p->host = NULL;
}

void rn_failure_line(const char *what, tnd_result r, char *buf, size_t cap)
{
    const char *d = tnd_error_detail();
    size_t n = strlen(what);
    if (strncmp(d, what, n) == 0 && d[n] == ':') /* (a message that names the command itself) */
        snprintf(buf, cap, "tandem: %s", d);
    else
        snprintf(buf, cap, "tandem: %s: %s", what, *d ? d : tnd_result_message(r));
}

const char *rn_signal_name(int sig)
{
    return sig == SIGINT ? "SIGINT" : sig == SIGTERM ? "SIGTERM" : "a signal";
}

tnd_log_level rn_quiet_begin(bool quiet)
{
    tnd_log_level was = tnd_log_get_level();
    if (quiet && was < TND_LOG_WARN)
        tnd_log_set_level(TND_LOG_WARN);
    return was;
}

void rn_quiet_end(tnd_log_level was)
{
    tnd_log_set_level(was);
}

/* ---- one writer per output directory --------------------------------------------------------- */
#define LOCK_NAME ".tandem.lock"

/* A file a killed writer left half-written: NAME.tmp or NAME.tmp.PID (tnd_file_write_atomic,
 * the EXR and sums writers) of a name a run writes (frame_*, *.json, video.mp4), whose process
 * is gone. Only called with the directory's lock held, so no other run is writing there. */
static bool debris(const char *name)
{
    const char *t = strstr(name, ".tmp");
    if (!t || t == name)
        return false;
    const char *rest = t + 4;
    if (*rest == '.') {
        char *end;
        long pid = strtol(rest + 1, &end, 10);
        if (rest[1] == 0 || *end || pid <= 0 || (kill((pid_t)pid, 0) == 0 || errno == EPERM))
            return false; /* (not a pid, or its process is still there) */
    } else if (*rest) {
        return false;
    }
    size_t base = (size_t)(t - name);
    return strncmp(name, "frame_", 6) == 0 ||
           (base >= 5 && strncmp(t - 5, ".json", 5) == 0) ||
           (base == 9 && strncmp(name, "video.mp4", 9) == 0);
}

static void remove_debris(const char *dir)
{
    DIR *d = opendir(dir);
    if (!d)
        return;
    for (struct dirent *e; (e = readdir(d));) {
        if (debris(e->d_name)) {
            char path[2400];
            snprintf(path, sizeof path, "%s/%s", dir, e->d_name);
            remove(path);
        }
    }
    closedir(d);
}

tnd_result rn_lock_dir(const char *dir, int *fd)
{
    char path[2200];
    snprintf(path, sizeof path, "%s/" LOCK_NAME, dir);
    *fd = open(path, O_RDWR | O_CREAT, 0644);
    if (*fd < 0)
        return tnd_fail(TND_ERR_IO, "%s: cannot create its lock %s: %s", dir, LOCK_NAME,
                        strerror(errno));
    struct flock fl = {.l_type = F_WRLCK, .l_whence = SEEK_SET};
    if (fcntl(*fd, F_SETLK, &fl) != 0) { /* (held by another process: released when it ends) */
        struct flock who = {.l_type = F_WRLCK, .l_whence = SEEK_SET};
        long pid = fcntl(*fd, F_GETLK, &who) == 0 && who.l_type != F_UNLCK ? (long)who.l_pid : 0;
        close(*fd);
        *fd = -1;
        return tnd_fail(TND_ERR_IO,
                        "%s: another tandem is writing there (process %ld holds %s/" LOCK_NAME
                        "): one run per output directory",
                        dir, pid, dir);
    }
    char text[32];
    int len = snprintf(text, sizeof text, "%ld\n", (long)getpid());
    if (ftruncate(*fd, 0) != 0 || write(*fd, text, (size_t)len) != len) {
        /* (the pid is for people; the lock is the fcntl lock) */
    }
    remove_debris(dir); /* (a run killed there before: SIGKILL leaves its temporary files) */
    return TND_OK;
}

void rn_unlock_dir(const char *dir, int fd)
{
    if (fd < 0)
        return;
    char path[2200];
    snprintf(path, sizeof path, "%s/" LOCK_NAME, dir);
    unlink(path);
    close(fd);
}

bool rn_remove_flat_dir(const char *dir)
{
    DIR *d = opendir(dir);
    if (!d)
        return false;
    bool ok = true;
    for (struct dirent *e; (e = readdir(d));) {
        if (strcmp(e->d_name, ".") == 0 || strcmp(e->d_name, "..") == 0)
            continue;
        char path[2400];
        snprintf(path, sizeof path, "%s/%s", dir, e->d_name);
        ok &= remove(path) == 0;
    }
    closedir(d);
    return ok && rmdir(dir) == 0;
}

/* ---- scenes, bounces --------------------------------------------------------------------------- */
tnd_result rn_scene_load(const char *path, const rn_env *env, tnd_scene **scene)
{
    if (env && env->up && strcmp(env->up, "y") != 0 && strcmp(env->up, "z") != 0)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "--up %s: y or z", env->up);
    tnd_scene_options o = {.env = env ? env->path : NULL,
                           .env_intensity = env ? (float)env->intensity : 1.0f,
                           .env_rotation = env ? (float)env->rotation : 0.0f,
                           .opaque = env && env->opaque,
                           .no_default_light = env && env->no_default_light,
                           .up_z = env && env->up && strcmp(env->up, "z") == 0,
                           .camera_path = env ? env->camera_path : NULL,
                           .path_duration = env ? env->path_duration : 0.0,
                           .path_radius = env ? env->path_radius : 0.0,
                           .path_height = env && isfinite(env->path_height) ? env->path_height : 0,
                           .path_height_given = env && isfinite(env->path_height)};
    return tnd_scene_load_with(path, &o, scene);
}

bool rn_bounces_parse(const char *v, unsigned max, unsigned *value)
{
    if (strcmp(v, "half") == 0) {
        *value = RN_BOUNCES_HALF;
        return true;
    }
    char *end;
    errno = 0;
    unsigned long x = strtoul(v, &end, 10);
    if (errno || *v == '-' || !*v || *end || x > max)
        return false;
    *value = (unsigned)x;
    return true;
}

unsigned rn_bounces_split(unsigned value, bool *half)
{
    *half = value == RN_BOUNCES_HALF;
    return *half ? 1 : value;
}

/* ---- frames, figures --------------------------------------------------------------------------- */
static int cmp_u32(const void *a, const void *b)
{
    uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
    return x < y ? -1 : x > y;
}

tnd_result rn_list_frames(const char *dir, uint32_t **frames, uint32_t *count)
{
    *frames = NULL;
    *count = 0;
    DIR *d = opendir(dir);
    if (!d)
        return tnd_fail(TND_ERR_IO, "%s: cannot open directory", dir);
    uint32_t cap = 0;
    for (struct dirent *e; (e = readdir(d));) {
        unsigned f;
        int end = 0;
        if (sscanf(e->d_name, "frame_%u.exr%n", &f, &end) != 1 || end == 0 ||
            e->d_name[end] != 0)
            continue;
        if (*count == cap) {
            cap = cap ? 2 * cap : 64;
            uint32_t *p = realloc(*frames, cap * sizeof *p);
            if (!p) {
                closedir(d);
                free(*frames);
                *frames = NULL;
                return tnd_fail(TND_ERR_OUT_OF_MEMORY, "eval: out of memory");
            }
            *frames = p;
        }
        (*frames)[(*count)++] = f;
    }
    closedir(d);
    if (*count)
        qsort(*frames, *count, sizeof **frames, cmp_u32);
    return TND_OK;
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

double rn_median(double *v, unsigned n)
{
    qsort(v, n, sizeof *v, cmp_double);
    return n ? v[n / 2] : 0.0;
}

void rn_timings_members(FILE *f, const pl_chain *chain, const pl_step_result *r)
{
    const pl_pass *p[64];
    double ms[64];
    uint32_t n = pl_chain_passes(chain, p, 64);
    pl_step_times(chain, r, ms);
    for (uint32_t i = 0; i < n; i++) {
        fprintf(f, ", \"%s\": %.4f", p[i]->key, ms[i]);
        if (p[i]->beside) /* e.g. "denoise_lf_beside_atrous" */
            fprintf(f, ", \"%.*s_beside_%s\": %s", (int)(strlen(p[i]->key) - 3), p[i]->key,
                    p[i]->beside, r->beside ? "true" : "false");
    }
}
