/* app/cmd_convert.c: `tandem convert --captures DIR --map MAPPING.json --out DIR`: another
 * renderer's sequence read through a mapping and written as Tandem captures
 * (DIR/frame_NNNN.exr, one per frame in the sequence's order), so that it can be looked at
 * entry by entry, compared (`tandem compare`) and replayed without the mapping. */
#include "app/app.h"

#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

static const app_cmd convert_cmd = {
    "convert",
    "Read another renderer's EXR sequence through a channel mapping and write it as Tandem\n"
    "captures (DIR/frame_NNNN.exr): the contract the denoiser would see.",
    "--captures DIR --map MAPPING.json --out DIR", NULL};

int cmd_convert(int argc, char **argv)
{
    const char *captures = NULL, *out = NULL, *map_path = NULL;
    const app_opt opts[] = {
        {"captures", APP_OPT_STRING, &captures, "DIR", "the sequence (or DIR/capture)"},
        {"map", APP_OPT_STRING, &map_path, "JSON", "its channel mapping (data/mappings/)"},
        {"out", APP_OPT_STRING, &out, "DIR", "output directory (created)"},
        {0},
    };
    const char *pos[1];
    int npos;
    int rc = app_parse(&convert_cmd, opts, argc, argv, pos, 0, &npos);
    if (rc >= 0)
        return rc;
    if (!captures || !out || !map_path) {
        fprintf(stderr, "tandem convert: --captures DIR, --map JSON and --out DIR are required\n");
        return APP_EXIT_USAGE;
    }
    if (strlen(out) > 1000)
        return app_report("convert", tnd_fail(TND_ERR_INVALID_ARGUMENT, "--out: path too long"));
    tnd_result res = TND_OK;
    tnd_capture_map *map = NULL;
    char dir[1100], src[2300], dst[1200];
    char **names = NULL;
    size_t n = 0;
    tnd_frame f = {0}, before = {0};
    struct stat st;
    bool out_existed = stat(out, &st) == 0, began = false;
    size_t written = 0;
    int status = APP_EXIT_FAIL;
    TND_TRY(tnd_capture_map_load(map_path, &map));
    TND_TRY((tnd_capture_dir(captures, dir, sizeof dir), tnd_capture_map_list(map, dir, &names, &n)));
    for (size_t i = 0; i < n; i++) {
        snprintf(src, sizeof src, "%s/%s", dir, names[i]);
        tnd_frame_destroy(&before);
        before = f;
        memset(&f, 0, sizeof f);
        TND_TRY(tnd_capture_read_mapped(src, map, i ? &before.camera : NULL, &f));
        if (i > 0 && (f.width != before.width || f.height != before.height)) {
            res = tnd_fail(TND_ERR_BAD_INPUT,
                           "capture: %s: %ux%u, the sequence's first frame "
                           "is %ux%u",
                           src, f.width, f.height, before.width, before.height);
            goto fail;
        }
        if (i > 0)
            TND_TRY(tnd_capture_check_entries(&before, &f, src));
        if (!began) {
            TND_TRY(tnd_mkdirs(out));
            began = true;
        }
        f.camera.frame_index = (uint32_t)i;
        snprintf(dst, sizeof dst, "%s/frame_%04zu.exr", out, i);
        TND_TRY(tnd_capture_write(dst, &f, TND_EXR_ZIP));
        written = i + 1;
    }
    if (!app_quiet())
        fprintf(stderr, "tandem: convert: %zu frame%s of %s (%s) -> %s/\n", n, n == 1 ? "" : "s",
                dir, tnd_capture_map_name(map), out);
    status = APP_EXIT_OK;
fail:
    if (status != APP_EXIT_OK) {
        app_report("convert", res);
        if (began && !out_existed) { /* no partial output */
            rn_remove_flat_dir(out);
        } else {
            for (size_t i = 0; began && i <= written && i < n; i++) {
                snprintf(dst, sizeof dst, "%s/frame_%04zu.exr", out, i);
                remove(dst);
            }
        }
    }
    tnd_frame_destroy(&f);
    tnd_frame_destroy(&before);
    tnd_capture_map_destroy(map);
    tnd_capture_list_free(names, n);
    return status;
}
