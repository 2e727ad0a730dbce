/* tests/plugins/broken.c: a plugin that is wrong in the way $TANDEM_TEST_BROKEN names, for the
 * loader's and the adapters' messages (tests/test_plugins.py):
 *   refuse  the entry returns NULL (another ABI)      abi     abi_version 99
 *   small   struct_size too small for the fields      kind    a denoiser where a front-end is asked
 *   no_hf   a front-end that does not write hf        create  create fails with a message
 *   render  the third frame fails with a message      (unset) a working front-end: a grey wall */
#include <tandem/tandem_plugin.h>

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const char *mode(void)
{
    const char *m = getenv("TANDEM_TEST_BROKEN");
    return m ? m : "";
}

static int b_create(const tandem_frontend_create_info *info, void **state, char *err,
                    uint32_t cap)
{
    (void)info;
    if (strcmp(mode(), "create") == 0) {
        snprintf(err, cap, "the broken plugin was asked to fail");
        return 1;
    }
    *state = calloc(1, 1);
    return *state ? 0 : 1;
}

static void b_destroy(void *state)
{
    free(state);
}

static int b_render(void *state, const tandem_frame_settings *s, tandem_host_frame *f, char *err,
                    uint32_t cap)
{
    (void)state;
    if (strcmp(mode(), "render") == 0 && s->frame_index == 2) {
        snprintf(err, cap, "frame 2 is where the broken plugin stops");
        return 1;
    }
    size_t n = (size_t)f->width * f->height;
    float *albedo = f->entries[TANDEM_ENTRY_ALBEDO], *normal = f->entries[TANDEM_ENTRY_NORMAL];
    float *depth = f->entries[TANDEM_ENTRY_DEPTH], *motion = f->entries[TANDEM_ENTRY_MOTION];
    float *hf = f->entries[TANDEM_ENTRY_HF];
    for (size_t q = 0; q < n; q++) {
        for (int k = 0; k < 3; k++) {
            albedo[3 * q + k] = 0.5f;
            normal[3 * q + k] = k == 2 ? 1.0f : 0.0f;
            motion[3 * q + k] = 0.0f;
            if (hf)
                hf[3 * q + k] = 1.0f;
        }
        depth[q] = 2.0f;
    }
    return 0;
}

static tandem_frontend_plugin frontend = {
    .struct_size = sizeof frontend,
    .writes = TANDEM_ENTRIES_REQUIRED,
    .create = b_create,
    .destroy = b_destroy,
    .render = b_render,
};

static tandem_plugin plugin = {
    .struct_size = sizeof plugin,
    .abi_version = TANDEM_PLUGIN_ABI_VERSION,
    .kind = TANDEM_PLUGIN_FRONTEND,
    .name = "broken",
    .frontend = &frontend,
};

__attribute__((visibility("default"))) const tandem_plugin *tandem_plugin_entry(uint32_t abi)
{
    const char *m = mode();
    if (strcmp(m, "refuse") == 0 || abi != TANDEM_PLUGIN_ABI_VERSION)
        return NULL;
    if (strcmp(m, "abi") == 0)
        plugin.abi_version = 99;
    if (strcmp(m, "small") == 0)
        plugin.struct_size = 8;
    if (strcmp(m, "kind") == 0)
        plugin.kind = TANDEM_PLUGIN_DENOISER;
    if (strcmp(m, "no_hf") == 0)
        frontend.writes &= ~TANDEM_ENTRY_BIT(TANDEM_ENTRY_HF);
    return &plugin;
}
