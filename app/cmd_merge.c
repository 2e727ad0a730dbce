/* app/cmd_merge.c: `tandem merge SHARD_DIR... --out DIR`: the shards of a reference added up
 * (rn_merge) into the frames one run of all the samples writes (docs/cluster.md). */
#include "app/app.h"

#include <string.h>

static const app_cmd merge_cmd = {
    "merge",
    "Merge the shards of a reference (tandem reference --shard I/N, on as many machines as you\n"
    "like) into the frames and reference.json one run of all the samples writes: the shards'\n"
    "per-pixel sums are added in the order of their samples. The shards must belong together\n"
    "(same scene, camera, size, path, estimator and samples) and cover every frame's samples\n"
    "exactly once; gaps and overlaps are refused by name.",
    "SHARD_DIR... --out DIR", NULL};

int cmd_merge(int argc, char **argv)
{
    enum { MERGE_MAX = 4096 };
    const char *out = NULL;
    const app_opt opts[] = {{"out", APP_OPT_STRING, &out, "DIR", "output directory (created)"},
                            {0}};
    const char *pos[MERGE_MAX];
    int npos;
    int rc = app_parse(&merge_cmd, opts, argc, argv, pos, MERGE_MAX, &npos);
    if (rc >= 0)
        return rc;
    if (!out || npos < 1) {
        fprintf(stderr, "tandem merge: give the shard directories and --out DIR (see tandem merge "
                        "--help)\n");
        return APP_EXIT_USAGE;
    }
    rn_host h = app_host();
    tnd_result res = rn_merge(pos, npos, out, &h);
    return res == TND_OK ? APP_EXIT_OK : app_report("merge", res);
}
