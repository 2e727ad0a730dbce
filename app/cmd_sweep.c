/* app/cmd_sweep.c: `tandem bench --sweep KEY=V1,V2,...` (app_sweep, from bench's options) and
 * `tandem sweep collect|resume DIR`: the run layer's sweeps (run/rn_sweep.c), their usage
 * errors, what they print. */
#include "app/app.h"

#include <string.h>

/* A sweep's result: the Slurm script's path, or the collected table, on stdout. */
static int sweep_done(const char *what, tnd_result res, rn_sweep_result *r)
{
    if (res == TND_OK && r->submit[0])
        printf("%s\n", r->submit);
    if (res == TND_OK && r->table.s)
        fputs(r->table.s, stdout);
    rn_sweep_result_free(r);
    return app_finish(what, res);
}

int app_sweep(const rn_sweep_opts *o)
{
    bool in_job = false;
    tnd_result res = rn_sweep_check(o, &in_job);
    if (res != TND_OK) { /* (the sweep's options: usage errors, before anything is written) */
        if (in_job)
            app_report("bench", res);
        else
            fprintf(stderr, "tandem bench: %s\n", tnd_error_detail());
        return APP_EXIT_USAGE;
    }
    rn_host h = app_host();
    rn_sweep_result r;
    res = rn_sweep(o, &h, &r);
    return sweep_done("bench", res, &r);
}

static const app_cmd sweep_cmd = {
    "sweep",
    "collect DIR: gather a sweep's finished cells (tandem bench --sweep ... --emit slurm, run on\n"
    "a cluster) into DIR/sweep.json, DIR/sweep.csv and DIR/report, as a local sweep writes them;\n"
    "cells that failed or have not run are named, in the outputs and on stderr (exit 1).\n"
    "resume DIR: go on with a local sweep that was interrupted (bench --sweep ... --out DIR):\n"
    "the jobs done are kept, an interrupted reference goes on, the rest run; then collect.",
    "collect DIR | resume DIR", NULL};

int cmd_sweep(int argc, char **argv)
{
    const app_opt opts[] = {{0}};
    const char *pos[2];
    int npos;
    int rc = app_parse(&sweep_cmd, opts, argc, argv, pos, 2, &npos);
    if (rc >= 0)
        return rc;
    if (npos != 2 || (strcmp(pos[0], "collect") != 0 && strcmp(pos[0], "resume") != 0)) {
        fprintf(stderr, "tandem sweep: expected 'collect DIR' or 'resume DIR' (see tandem sweep "
                        "--help)\n");
        return APP_EXIT_USAGE;
    }
    rn_host h = app_host();
    rn_sweep_result r;
    tnd_result res = strcmp(pos[0], "resume") == 0 ? rn_sweep_resume(pos[1], &h, &r)
                                                   : rn_sweep_collect(pos[1], &h, &r);
    return sweep_done("sweep", res, &r);
}
