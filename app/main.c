/* app/main.c: `tandem COMMAND [options]`: dispatches to the subcommands. */
#include "app/app.h"

#include <string.h>

static const app_cmd commands[] = {
    {"info", "Show the Vulkan devices and their ray-tracing support, or a scene's contents.",
     "[--json] [--device INDEX|NAME] [--scene PATH]", cmd_info},
    {"render", "Render a scene's camera path through a front-end (contract, composite, preview).",
     "--out DIR [options]", cmd_render},
    {"view", "The pipeline live in a window: fly the camera, turn the knobs, see every buffer.",
     "[--scene PATH] [--script FILE] [options]", cmd_view},
    {"reference", "Render converged reference frames (unbiased path tracing).",
     "--out DIR [options]", cmd_reference},
    {"sweep", "Gather a sweep run elsewhere (bench --sweep --emit slurm) into its report.",
     "collect DIR", cmd_sweep},
    {"merge", "Merge the shards of a reference (reference --shard I/N) into its frames.",
     "SHARD_DIR... --out DIR", cmd_merge},
    {"denoise", "Run the denoising back-end on a captured EXR sequence (Tandem's or another's).",
     "--captures DIR --out DIR [--map JSON]", cmd_denoise},
    {"bench", "Measure a front-end: ms per pass, Mrays/s, and the raw ray-casting rate.",
     "[--scene PATH] [--size WxH] [--repeats N] [--json]", cmd_bench},
    {"convert", "Read another renderer's EXR sequence through a mapping; write Tandem captures.",
     "--captures DIR --map JSON --out DIR", cmd_convert},
    {"compare", "Compare two capture directories channel by channel (front-end cross-check).",
     "A B [options]", cmd_compare},
    {"dataset", "Render training data for learned denoisers: contract, noisy, matched reference.",
     "SPEC.json --out DIR [--shard I/N]", cmd_dataset},
    {"rank", "Rank denoisers over a suite of sequences: the leaderboard with 95% intervals.",
     "SUITE --denoisers A,B,... --out DIR", cmd_rank},
    {"eval", "Evaluate a run against converged references: metrics, JSON/CSV, HTML report.",
     "--out DIR --reference REFDIR [--report REPORTDIR]", cmd_eval},
    {"contract", "Print the buffer contract: every entry, its EXR channels, formats and meaning.",
     "[--json]", cmd_contract},
};
static const int command_count = (int)(sizeof commands / sizeof commands[0]);

static void usage(FILE *f)
{
    fprintf(f,
            "usage: tandem COMMAND [options]\n\n"
            "Tandem %s: denoiser-centric real-time path tracing.\n\ncommands:\n",
            TND_VERSION_STRING);
    for (int i = 0; i < command_count; i++)
        fprintf(f, "  %-10s %s\n", commands[i].name, commands[i].summary);
    fprintf(f, "\n'tandem COMMAND --help' describes a command's options.\n"
               "Environment: TANDEM_DEVICE=<index or name> picks a device (as --device); "
               "TANDEM_VALIDATION=1 enables the Vulkan validation layer.\n");
}

int main(int argc, char **argv)
{
    if (argc < 2) {
        usage(stderr);
        return APP_EXIT_USAGE;
    }
    if (strcmp(argv[1], "--help") == 0 || strcmp(argv[1], "-h") == 0 ||
        strcmp(argv[1], "help") == 0) {
        usage(stdout);
        return APP_EXIT_OK;
    }
    if (strcmp(argv[1], "--version") == 0) {
        printf("tandem %s\n", TND_VERSION_STRING);
        return APP_EXIT_OK;
    }
    app_interrupts_install();
    for (int i = 0; i < command_count; i++)
        if (strcmp(argv[1], commands[i].name) == 0)
            return commands[i].run(argc - 1, argv + 1);
    fprintf(stderr, "tandem: unknown command '%s'\n\n", argv[1]);
    usage(stderr);
    return APP_EXIT_USAGE;
}
