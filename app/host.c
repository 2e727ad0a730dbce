/* app/host.c: the command line as the run layer's host: its lines on stderr (a line said while
 * a progress bar is drawn starts on a line of its own), its progress as the bar, its interrupts
 * from SIGINT and SIGTERM; and a run's result as the command's exit status.
 * Entry points: app_host, app_finish. */
#include "app/app.h"

enum { BARS_MAX = 4 }; /* a run's bar inside another's (a compare's render, then its eval) */
static app_progress bars[BARS_MAX];
static int nbars;

static bool bar_drawn(void)
{
    return nbars > 0 && nbars <= BARS_MAX && bars[nbars - 1].enabled;
}

static void on_line(void *user, const char *line)
{
    (void)user;
    fprintf(stderr, "%s%s\n", bar_drawn() ? "\n" : "", line);
}

static void on_progress(void *user, rn_progress_phase phase, const char *label, uint64_t done,
                        uint64_t total)
{
    (void)user;
    if (phase == RN_PROGRESS_BEGIN) {
        if (nbars < BARS_MAX)
            app_progress_begin(&bars[nbars], label, (unsigned)total);
        nbars++;
    } else if (nbars > 0 && nbars <= BARS_MAX) {
        app_progress *p = &bars[nbars - 1];
        if (phase == RN_PROGRESS_STEP) {
            app_progress_step(p, (unsigned)done);
        } else {
            app_progress_end(p);
            nbars--;
        }
    } else if (phase == RN_PROGRESS_END && nbars > 0) {
        nbars--;
    }
}

static int on_interrupted(void *user)
{
    (void)user;
    return app_interrupted();
}

rn_host app_host(void)
{
    return (rn_host){.message = on_line, .warning = on_line, .progress = on_progress,
                     .interrupted = on_interrupted, .quiet = app_quiet()};
}

int app_finish(const char *what, tnd_result r)
{
    if (r == TND_OK)
        return APP_EXIT_OK;
    if (r == TND_ERR_INTERRUPTED) /* (the run said where it stopped) */
        return app_interrupt_status();
    return app_report(what, r);
}
