/* app/cmd_dataset.c: `tandem dataset SPEC.json --out DIR [--shard I/N]`: training data for
 * learned denoisers (rn_dataset, run/rn_dataset.c; docs/python.md). */
#include "app/app.h"

static const app_cmd dataset_cmd = {
    "dataset",
    "Render training data: per frame the contract, the noisy composite and the matched reference.",
    "SPEC.json --out DIR [--shard I/N]", NULL};

int cmd_dataset(int argc, char **argv)
{
    const char *out = NULL, *shard = NULL;
    const app_opt opts[] = {
        {"out", APP_OPT_STRING, &out, "DIR", "where the sequences and the manifest go"},
        {"shard", APP_OPT_STRING, &shard, "I/N",
         "this shard's frames of N (frame k of the set when k mod N = I): "
         "DIR/manifest-I-of-N.json"},
        {0},
    };
    const char *pos[1];
    int npos = 0;
    int rc = app_parse(&dataset_cmd, opts, argc, argv, pos, 1, &npos);
    if (rc >= 0)
        return rc;
    if (npos != 1 || !out) {
        fprintf(stderr, "tandem dataset: SPEC.json and --out DIR are required (see tandem dataset "
                        "--help)\n");
        return APP_EXIT_USAGE;
    }
    rn_host h = app_host();
    tnd_result r = rn_dataset(pos[0], out, shard, &h);
    return r == TND_OK ? APP_EXIT_OK : app_report("dataset", r);
}
