/* app/cmd_rank.c: `tandem rank SUITE --denoisers A,B,... --out DIR`: the denoiser leaderboard
 * (rn_rank, run/rn_rank.c; docs/rank.md): its options, its usage errors, the table on stdout. */
#include "app/app.h"

static const app_cmd rank_cmd = {
    "rank",
    "Rank denoisers over a suite of sequences against their matched references: per sequence\n"
    "and denoiser relMSE, FLIP, temporal error, flicker, lags, worth-N-samples and back-end time,\n"
    "each quality figure with a 95% interval (a paired bootstrap over frames) and ties marked;\n"
    "the overall rank by the geometric mean of FLIP over the baseline's (svgf where named).\n"
    "SUITE: a JSON file (docs/rank.md) or a shipped suite's name (quick, standard). References\n"
    "are made once into the cache and reused; the same command again goes on where an\n"
    "interrupted rank stopped. Writes DIR/rank.json, DIR/rank.csv and DIR/report/index.html.",
    "SUITE --denoisers A,B,... --out DIR [--cache DIR] [--emit slurm]", NULL};

int cmd_rank(int argc, char **argv)
{
    rn_rank_opts o = {0};
    bool no_report = false, regions = false;
    const app_opt opts[] = {
        {"denoisers", APP_OPT_STRING, &o.denoisers, "A,B,...",
         "the denoisers: registered names, plugin:PATH.so, python:MODULE:CALLABLE; each may "
         "carry settings, NAME@KEY=VALUE@... (taa=on|off|W, lights=auto|plain|tree|restir, or a "
         "parameter of that denoiser: recurrent@taa=0.2@atrous=5, asvgf@lights=plain)"},
        {"out", APP_OPT_STRING, &o.out, "DIR", "where the runs, rank.json, rank.csv, report go"},
        {"cache", APP_OPT_STRING, &o.cache, "DIR",
         "the matched references' cache (default: $TANDEM_CACHE/references, else "
         "$XDG_CACHE_HOME/tandem/references, else ~/.cache/tandem/references)"},
        {"emit", APP_OPT_STRING, &o.emit, "slurm",
         "write the references and renders as Slurm jobs (DIR/slurm/submit.sh), the rank last"},
        {"bootstrap", APP_OPT_UINT, &o.bootstrap, "N",
         "bootstrap replicates for the intervals (default 1000)"},
        {"no-report", APP_OPT_FLAG, &no_report, NULL, "rank.json and rank.csv only"},
        {"regions", APP_OPT_FLAG, &regions, NULL,
         "the error per region (emitters and their edges, glossy, newly visible, moving, thin, "
         "mirror, glass) from the first denoiser's captures"},
        {0},
    };
    const char *pos[1];
    int npos = 0;
    int rc = app_parse(&rank_cmd, opts, argc, argv, pos, 1, &npos);
    if (rc >= 0)
        return rc;
    o.suite = npos == 1 ? pos[0] : NULL;
    o.no_report = no_report;
    o.regions = regions;
    tnd_result res = rn_rank_check(&o);
    if (res != TND_OK) { /* (before anything runs: the options, the suite, its files) */
        fprintf(stderr, "tandem rank: %s\n", tnd_error_detail());
        return res == TND_ERR_INVALID_ARGUMENT ? APP_EXIT_USAGE : APP_EXIT_FAIL;
    }
    rn_host h = app_host();
    rn_rank_result r;
    res = rn_rank(&o, &h, &r);
    if (res == TND_OK && r.submit[0])
        printf("%s\n", r.submit);
    if (res == TND_OK && r.table.s && !app_quiet())
        fputs(r.table.s, stdout);
    rn_rank_result_free(&r);
    return app_finish("rank", res);
}
