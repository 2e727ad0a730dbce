/* tests/install/sequence.c: docs/library.md's program, built against the installed libtandem
 * (tests/test_install.sh): a sequence rendered through the real-time pipeline, its matched
 * reference (the same estimator's expectation), and the run evaluated against it; what `tandem
 * render`, `tandem reference --estimator realtime` and `tandem eval` do, as functions.
 *     sequence SCENE OUT      -> OUT/run, OUT/matched, OUT/run/metrics.json */
#include <tandem/tandem.h>

#include <stdio.h>

int main(int argc, char **argv)
{
    if (argc != 3)
        return fprintf(stderr, "usage: sequence SCENE OUT\n"), 2;
    char run[1024], matched[1024];
    snprintf(run, sizeof run, "%s/run", argv[2]);
    snprintf(matched, sizeof matched, "%s/matched", argv[2]);
    rn_render_opts o; /* render's options, from its defaults */
    rn_render_defaults(&o);
    o.scene = argv[1], o.frontend = "embree", o.denoiser = "svgf", o.frames = 4;
    o.size[0] = 64, o.size[1] = 40, o.out = run, o.quiet = true;
    rn_render_opts m = o; /* the matched reference: the same path, the estimator's expectation */
    m.estimator = "realtime", m.spp = 32, m.out = matched;
    rn_eval_result e = {0};
    tnd_result r = rn_render(&o, false, NULL);
    if (r == TND_OK)
        r = rn_render(&m, true, NULL);
    if (r == TND_OK)
        r = rn_eval_sequence(&(rn_eval_opts){.out = run, .matched = matched, .metrics_on = "cpu"},
                             NULL, &e);
    if (r != TND_OK)
        return fprintf(stderr, "sequence: %s\n", tnd_error_detail()), 1;
    const ev_summary *s = &e.e.series[0].summary; /* the denoiser's error, over the frames */
    printf("%u frames: relMSE %.6g, FLIP %.6g\n", e.e.count, s->relmse, s->flip);
    rn_eval_result_free(&e);
    return 0;
}
