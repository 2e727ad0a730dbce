/* app/options.c: one option parser for every subcommand (--name VALUE or --name=VALUE), help
 * text generated from the same table, and the progress bar. */
#include "app/app.h"

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <signal.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static bool quiet_flag;

/* ---- interrupts ---------------------------------------------------------------------------- */
static volatile sig_atomic_t interrupt_signal;

static void on_interrupt(int sig)
{
    interrupt_signal = sig;
}

void app_interrupts_install(void)
{
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_interrupt;
    sigemptyset(&sa.sa_mask);
    sa.sa_flags = SA_RESETHAND; /* (a second signal ends the process at once) */
    sigaction(SIGINT, &sa, NULL);
    sigaction(SIGTERM, &sa, NULL);
}

int app_interrupted(void)
{
    return interrupt_signal;
}

int app_interrupt_status(void)
{
    return 128 + interrupt_signal;
}

bool app_quiet(void)
{
    return quiet_flag;
}

static tnd_log_level loud_level = TND_LOG_INFO; /* the log level before --quiet */

bool app_set_quiet(bool quiet)
{
    bool was = quiet_flag;
    if (quiet && !was)
        loud_level = tnd_log_get_level();
    quiet_flag = quiet;
    tnd_log_set_level(quiet ? TND_LOG_WARN : loud_level);
    return was;
}

static void print_help(const app_cmd *cmd, const app_opt *opts)
{
    printf("usage: tandem %s %s\n\n%s\n\noptions:\n", cmd->name, cmd->usage, cmd->summary);
    for (const app_opt *o = opts; o && o->name; o++) {
        char left[64];
        snprintf(left, sizeof left, "--%s%s%s", o->name, o->arg ? " " : "", o->arg ? o->arg : "");
        printf("  %-26s %s\n", left, o->help);
    }
    printf("  %-26s %s\n", "--device INDEX|NAME",
           "the Vulkan device: its index as tandem info lists them, or part of its name "
           "(also $TANDEM_DEVICE)");
    printf("  %-26s %s\n", "--quiet", "no progress or information messages on stderr");
    printf("  %-26s %s\n", "--help", "show this help");
}

static int parse_value(const app_cmd *cmd, const app_opt *o, const char *v)
{
    char *end = NULL;
    errno = 0;
    switch (o->kind) {
    case APP_OPT_FLAG:
        *(bool *)o->dest = true;
        return 0;
    case APP_OPT_STRING:
        *(const char **)o->dest = v;
        return 0;
    case APP_OPT_LIST: {
        app_list *l = o->dest;
        if (l->n >= APP_LIST_MAX) {
            fprintf(stderr, "tandem %s: --%s: at most %d times\n", cmd->name, o->name, APP_LIST_MAX);
            return -1;
        }
        l->v[l->n++] = v;
        return 0;
    }
    case APP_OPT_INT: {
        long x = strtol(v, &end, 10);
        if (errno || !*v || *end || x < -2147483647L || x > 2147483647L)
            break;
        *(int *)o->dest = (int)x;
        return 0;
    }
    case APP_OPT_BOUNCES: /* a count, or half */
        if (!rn_bounces_parse(v, RN_BOUNCES_HALF - 1, (unsigned *)o->dest))
            break;
        return 0;
    case APP_OPT_UINT: {
        if (*v == '-')
            break;
        unsigned long x = strtoul(v, &end, 10);
        if (errno || !*v || *end || x > 0xffffffffUL)
            break;
        *(unsigned *)o->dest = (unsigned)x;
        return 0;
    }
    case APP_OPT_FLOAT: {
        double x = strtod(v, &end);
        if (errno || !*v || *end || !isfinite(x)) /* (no option takes nan or inf) */
            break;
        *(double *)o->dest = x;
        return 0;
    }
    case APP_OPT_SIZE: {
        unsigned *wh = o->dest;
        unsigned long w = strtoul(v, &end, 10);
        if (*v == '-' || end == v || (*end != 'x' && *end != 'X'))
            break;
        const char *h0 = end + 1;
        unsigned long h = strtoul(h0, &end, 10);
        if (*h0 == '-' || end == h0 || *end || w == 0 || h == 0 || w > 65535 || h > 65535)
            break;
        wh[0] = (unsigned)w;
        wh[1] = (unsigned)h;
        return 0;
    }
    }
    fprintf(stderr, "tandem %s: --%s: bad value '%s'%s\n", cmd->name, o->name, v,
            o->kind == APP_OPT_SIZE      ? " (expected WxH, e.g. 640x360)"
            : o->kind == APP_OPT_BOUNCES ? " (expected a count or half)"
                                         : "");
    return -1;
}

int app_parse(const app_cmd *cmd, const app_opt *opts, int argc, char **argv, const char **pos,
              int max_pos, int *npos)
{
    *npos = 0;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (strcmp(a, "--help") == 0 || strcmp(a, "-h") == 0) {
            print_help(cmd, opts);
            return APP_EXIT_OK;
        }
        if (strcmp(a, "--quiet") == 0 || strcmp(a, "-q") == 0) {
            app_set_quiet(true);
            continue;
        }
        if (strcmp(a, "--device") == 0 || strncmp(a, "--device=", 9) == 0) {
            /* every command's: the Vulkan device, as $TANDEM_DEVICE picks it */
            const char *v = a[8] == '=' ? a + 9 : i + 1 < argc ? argv[++i] : NULL;
            if (!v || !*v) {
                fprintf(stderr, "tandem %s: --device needs an index or a name\n", cmd->name);
                return APP_EXIT_USAGE;
            }
            setenv("TANDEM_DEVICE", v, 1);
            continue;
        }
        if (strncmp(a, "--", 2) != 0 || a[2] == '\0') {
            if (*npos >= max_pos) {
                fprintf(stderr, "tandem %s: unexpected argument '%s' (see tandem %s --help)\n",
                        cmd->name, a, cmd->name);
                return APP_EXIT_USAGE;
            }
            pos[(*npos)++] = a;
            continue;
        }
        const char *name = a + 2, *eq = strchr(name, '=');
        size_t len = eq ? (size_t)(eq - name) : strlen(name);
        const app_opt *o = opts;
        while (o && o->name && !(strlen(o->name) == len && strncmp(o->name, name, len) == 0))
            o++;
        if (!o || !o->name) {
            fprintf(stderr, "tandem %s: unknown option '--%.*s' (see tandem %s --help)\n",
                    cmd->name, (int)len, name, cmd->name);
            return APP_EXIT_USAGE;
        }
        const char *v = NULL;
        if (o->kind != APP_OPT_FLAG) {
            if (eq)
                v = eq + 1;
            else if (i + 1 < argc)
                v = argv[++i];
            else {
                fprintf(stderr, "tandem %s: --%s needs a value (%s)\n", cmd->name, o->name,
                        o->arg ? o->arg : "VALUE");
                return APP_EXIT_USAGE;
            }
        } else if (eq) {
            fprintf(stderr, "tandem %s: --%s takes no value\n", cmd->name, o->name);
            return APP_EXIT_USAGE;
        }
        if (parse_value(cmd, o, v) != 0)
            return APP_EXIT_USAGE;
    }
    return -1;
}

int app_report(const char *what, tnd_result r)
{
    char line[4200];
    rn_failure_line(what, r, line, sizeof line);
    fprintf(stderr, "%s\n", line);
    return APP_EXIT_FAIL;
}

void app_progress_begin(app_progress *p, const char *label, unsigned total)
{
    *p = (app_progress){.label = label, .total = total, .start = tnd_now()};
    p->enabled = !quiet_flag && isatty(STDERR_FILENO);
    app_progress_step(p, 0);
}

void app_progress_step(app_progress *p, unsigned done)
{
    p->done = done;
    if (!p->enabled)
        return;
    double now = tnd_now();
    if (done != 0 && done != p->total && now - p->last_draw < 0.1)
        return;
    p->last_draw = now;
    const int width = 30;
    int fill = p->total ? (int)((double)width * done / p->total) : width;
    char bar[64];
    for (int i = 0; i < width; i++)
        bar[i] = i < fill ? '#' : '.';
    bar[width] = '\0';
    double el = now - p->start;
    double eta = done ? el * (p->total - done) / done : 0.0;
    fprintf(stderr, "\r%s [%s] %u/%u  %.1fs elapsed, %.1fs left ", p->label, bar, done, p->total,
            el, eta);
    fflush(stderr);
}

void app_progress_end(app_progress *p)
{
    if (!p->enabled)
        return;
    app_progress_step(p, p->total);
    fputc('\n', stderr);
}

/* ---- the registries' tables as options and outputs --------------------------------------------- */
bool app_opts_with_params(const app_opt *base, app_opt *out, size_t cap, double *vals)
{
    size_t n = 0;
    for (const app_opt *o = base; o && o->name; o++) {
        if (n + 1 >= cap)
            return false;
        out[n++] = *o;
    }
    for (uint32_t i = 0; i < pl_param_count(); i++) {
        const pl_param *p = pl_param_at(i);
        if (n + 1 >= cap)
            return false;
        vals[i] = NAN;
        out[n++] = (app_opt){p->name, APP_OPT_FLOAT, &vals[i], p->arg, p->help};
    }
    out[n] = (app_opt){0};
    return true;
}

tnd_result app_params_collect(const double *vals, pl_param_set *set)
{
    for (uint32_t i = 0; i < pl_param_count(); i++)
        if (!isnan(vals[i]))
            TND_TRY_RETURN(pl_param_set_put(set, pl_param_at(i)->name, vals[i]));
    return TND_OK;
}
