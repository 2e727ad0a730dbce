/* tests/plugins/host_copy.c: a host denoiser plugin (TANDEM_PLUGIN_HOST_DENOISER) that returns
 * the noisy radiance it is given, so that a render through it equals `--denoiser off` bit for
 * bit (tests/test_plugins.py): the contract and the radiance come to the host and the output goes
 * back up unchanged. TANDEM_TEST_HOST=fail: frame 1 fails with a message; =noradiance: it
 * checks that the entries it reads arrive (albedo and depth) and the others do not; =crash:
 * frame 2 dies of SIGSEGV (as a plugin's bad pointer would); =nan: its output holds NaN from
 * frame 1 on (tests/test_rank.sh: the rank goes on without its row). */
#include <tandem/tandem_plugin.h>

#include <math.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const char *mode(void)
{
    const char *m = getenv("TANDEM_TEST_HOST");
    return m ? m : "";
}

static int h_create(const tandem_host_denoiser_create_info *info, void **state, char *err,
                    uint32_t cap)
{
    if (info->width == 0 || info->height == 0 || !info->options) {
        snprintf(err, cap, "no size or options");
        return 1;
    }
    *state = calloc(1, 1);
    return *state ? 0 : 1;
}

static void h_destroy(void *state)
{
    free(state);
}

static int h_run(void *state, const tandem_frame_settings *s, const tandem_host_denoiser_io *io,
                 char *err, uint32_t cap)
{
    (void)state;
    if (strcmp(mode(), "fail") == 0 && s->frame_index == 1) {
        snprintf(err, cap, "host_copy fails at frame 1 as asked");
        return 1;
    }
    if (!io->radiance || !io->entries[TANDEM_ENTRY_ALBEDO] || !io->entries[TANDEM_ENTRY_DEPTH] ||
        io->entries[TANDEM_ENTRY_HF] || s->width != io->width) {
        snprintf(err, cap, "the buffers it reads, and only those, should have come");
        return 1;
    }
    if (strcmp(mode(), "crash") == 0 && s->frame_index == 2) {
        signal(SIGSEGV, SIG_DFL); /* (a sanitizer's handler would make it an exit) */
        raise(SIGSEGV);
    }
    memcpy(io->output, io->radiance, (size_t)io->width * io->height * 4 * sizeof(float));
    if (strcmp(mode(), "nan") == 0 && s->frame_index >= 1)
        for (size_t q = 0; q < (size_t)io->width * io->height; q += 7)
            io->output[4 * q] = NAN;
    return 0;
}

static const tandem_host_denoiser_plugin host = {
    .struct_size = sizeof host,
    .reads = TANDEM_ENTRY_BIT(TANDEM_ENTRY_ALBEDO) | TANDEM_ENTRY_BIT(TANDEM_ENTRY_DEPTH) |
             TANDEM_INPUT_RADIANCE,
    .create = h_create,
    .destroy = h_destroy,
    .run = h_run,
};

static const tandem_plugin desc = {
    .struct_size = sizeof desc,
    .abi_version = TANDEM_PLUGIN_ABI_VERSION,
    .kind = TANDEM_PLUGIN_HOST_DENOISER,
    .name = "host_copy",
    .description = "the noisy radiance, unchanged, through the host",
    .host_denoiser = &host,
};

__attribute__((visibility("default"))) const tandem_plugin *tandem_plugin_entry(uint32_t abi)
{
    return abi == TANDEM_PLUGIN_ABI_VERSION ? &desc : NULL;
}
