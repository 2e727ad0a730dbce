/* app/cmd_denoise.c: `tandem denoise --captures DIR [--map MAPPING.json] --out DIR`: the back-end
 * on an EXR sequence, Tandem's own captures or another renderer's through a channel mapping
 * (docs/captures.md). Writes the same outputs as render: DIR/frame_NNNN.exr (linear HDR),
 * DIR/frame_NNNN.png (preview), DIR/timings.json. */
#include "app/app.h"
#include "composite/composite.h"
#include "denoise/denoise.h"
#include "pipeline/pipeline.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include <sys/stat.h>

static const app_cmd denoise_cmd = {
    "denoise",
    "Run the denoising back-end on a captured EXR sequence (Tandem's captures, or another\n"
    "renderer's through --map) and write the denoised frames.",
    "--captures DIR --out DIR [--map MAPPING.json] [--denoiser NAME] [--dump LIST]", NULL};

int cmd_denoise(int argc, char **argv)
{
    const char *captures = NULL, *out = NULL, *map_path = NULL, *denoiser = pl_denoiser_default(), *dump = NULL;
    const char *taa = "on";
    double yfov_deg = 40.0;
    char dn_help[300];
    snprintf(dn_help, sizeof dn_help,
             "the denoiser: %s, plugin:PATH.so or python:MODULE:CALLABLE (default asvgf; one that "
             "needs gradient samples runs as its fallback on captures without them)",
             pl_denoiser_names());
    const app_opt opts[] = {
        {"captures", APP_OPT_STRING, &captures, "DIR",
         "directory of frame_NNNN.exr (or DIR/capture; another renderer's with --map)"},
        {"out", APP_OPT_STRING, &out, "DIR", "output directory (created)"},
        {"map", APP_OPT_STRING, &map_path, "JSON", "channel mapping for other renderers' EXRs"},
        {"dump", APP_OPT_STRING, &dump, "LIST",
         "also write back-end buffers to DIR/dump/NAME_NNNN.exr (names: see tandem render --help)"},
        {"denoiser", APP_OPT_STRING, &denoiser, "NAME", dn_help},
        {"taa", APP_OPT_STRING, &taa, "on|off|W",
         "temporal anti-aliasing of the output (on: new-frame weight 0.1; off: the composite "
         "itself)"},
        {"yfov", APP_OPT_FLOAT, &yfov_deg, "DEG",
         "vertical field of view for captures without camera matrices (default 40)"},
        {0},
    };
    app_opt with_params[32]; /* and the denoisers' parameters (pl_param) */
    double param_vals[PL_PARAMS_MAX];
    if (!app_opts_with_params(opts, with_params, 32, param_vals))
        return APP_EXIT_FAIL;
    const char *pos[1];
    int npos;
    int rc = app_parse(&denoise_cmd, with_params, argc, argv, pos, 0, &npos);
    if (rc >= 0)
        return rc;
    if (!captures || !out) {
        fprintf(stderr, "tandem denoise: --captures DIR and --out DIR are required\n");
        return APP_EXIT_USAGE;
    }
    tnd_result res = TND_OK;
    const pl_denoiser_info *dn;
    pl_param_set params = {0};
    if ((res = pl_denoiser_find(denoiser, &dn)) != TND_OK ||
        (res = app_params_collect(param_vals, &params)) != TND_OK)
        return app_report("denoise", res);
    if (dump && !(dn->caps & PL_DN_DUMPS))
        return app_report("denoise", tnd_fail(TND_ERR_INVALID_ARGUMENT,
                                              "--dump shows the back-end's buffers: with a "
                                              "denoiser plugin they are not the denoiser's"));
    if (strlen(out) > 1000 || strlen(captures) > 1000)
        return app_report("denoise",
                          tnd_fail(TND_ERR_INVALID_ARGUMENT, "--out/--captures: path too long"));
    uint32_t dump_mask = 0;
    if ((res = rn_dump_parse(dump, &dump_mask)) != TND_OK)
        return app_report("denoise", res);
    cmp_desc post_d = {0};
    if ((res = rn_taa_parse(taa, &post_d)) != TND_OK)
        return app_report("denoise", res);
    char path[2300];
    tnd_capture_map *map = NULL;
    pl_frontend *rp = NULL; /* the captures, replayed as a front-end */
    if (map_path && (res = tnd_capture_map_load(map_path, &map)) != TND_OK)
        return app_report("denoise", res);
    if ((res = pl_frontend_create("replay", NULL,
                                  &(pl_frontend_desc){.captures = captures, .map = map}, &rp)) !=
        TND_OK) {
        tnd_capture_map_destroy(map);
        return app_report("denoise", res);
    }
    size_t n = pl_frontend_length(rp);
    /* no partial output: what this run wrote goes again if a later frame fails */
    struct stat out_st;
    bool out_existed = stat(out, &out_st) == 0, dump_made = false;
    size_t written = 0;
    bool begun = false; /* the output was begun */
    int lock_fd = -1;   /* the output directory's lock */
    tnd_vk vk = {0};
    pl_chain *chain = NULL; /* selection, re-shading (the stored samples), back-end, post */
    float *rgb = NULL;
    uint8_t *display = NULL;
    FILE *timings = NULL;
    int status = APP_EXIT_FAIL;
    uint32_t w = 0, h = 0;
    tnd_precision prec = TND_PRECISION_F32;
    bool split = false;
    char dump_dir[1100];
    app_progress bar;
    app_progress_begin(&bar, "denoise", (unsigned)n);
    pl_frontend_recorded(rp, &w, &h, &prec, &split);
    /* A denoiser that needs re-shaded gradient samples (A-SVGF) runs on captures that keep them
     * (tandem render --capture --denoiser asvgf), and as its fallback on the others */
    const pl_denoiser_info *asked = dn;
    dn = pl_denoiser_for(asked, pl_frontend_caps(rp));
    if (dn != asked && !app_quiet())
        fprintf(stderr,
                "tandem: denoise: %s: running as %s: the capture carries no gradient samples (%s "
                "needs a front-end to re-shade them: tandem render --capture --denoiser %s keeps "
                "them)\n",
                pl_frontend_frame_name(rp, 0), dn->name, asked->name, asked->name);
    /* entries a denoiser uses where given, which captures from before their contract version
     * (and other renderers' through a mapping) lack: the recurrent denoiser follows reflections
     * by spec_hit (version 3), the built-in filters keep diffuse_view out of their histories (4) */
    static const struct {
        uint32_t cap;
        tnd_ct entry;
        const char *without;
    } optional[] = {
        {PL_DN_SPEC_HIT, TND_CT_SPEC_HIT,
         "moves reflections with their surfaces (no virtual motion)"},
        {PL_DN_DIFFUSE_VIEW, TND_CT_DIFFUSE_VIEW,
         "keeps the diffuse lobe's view factor in its histories (a moving camera's grazing "
         "surfaces lag)"}};
    for (size_t i = 0; i < sizeof optional / sizeof *optional && !app_quiet(); i++)
        if ((dn->caps & optional[i].cap) && !pl_frontend_recorded_has(rp, optional[i].entry)) {
            char ch[64];
            tnd_ct_exr_name(optional[i].entry, 0, ch, sizeof ch);
            fprintf(stderr, "tandem: denoise: %s: the captures carry no %s: %s %s\n",
                    pl_frontend_frame_name(rp, 0), ch, dn->name, optional[i].without);
        }
    const char *dn_name = dn->caps & PL_DN_PLUGIN ? denoiser : dn->name;
    pl_param_set own = {0}; /* the parameters it has */
    for (uint32_t i = 0; i < params.n; i++) {
        if (pl_denoiser_has_param(dn, params.param[i]->name))
            TND_TRY(pl_param_set_put(&own, params.param[i]->name, params.value[i]));
        else if (!app_quiet())
            fprintf(stderr, "tandem: denoise: --%s: %s has no such parameter (left out)\n",
                    params.param[i]->name, dn->name);
    }
    TND_TRY(tnd_vk_create(&(tnd_vk_desc){.no_ray_tracing = true}, &vk));
    /* the post chain with render's defaults (auto exposure, ACES), TAA as asked, the interleave
     * when the captures carry split paths (the first frame says) */
    post_d.interleave = split;
    TND_TRY(pl_chain_create(&(pl_chain_desc){.vk = &vk, .width = w, .height = h,
                                             .precision = prec, .backend = true,
                                             .denoiser = dn_name, .params = own,
                                             .post = post_d},
                            &chain));
    rgb = malloc((size_t)w * h * 3 * sizeof *rgb);
    display = malloc((size_t)w * h * 3);
    if (!rgb || !display) {
        res = tnd_fail(TND_ERR_OUT_OF_MEMORY, "denoise: out of memory");
        goto fail;
    }
    TND_TRY(tnd_mkdirs(out));
    TND_TRY(rn_lock_dir(out, &lock_fd)); /* (before anything is written or removed there) */
    begun = true;
    if (dump_mask) {
        struct stat dst;
        snprintf(dump_dir, sizeof dump_dir, "%s/dump", out);
        dump_made = stat(dump_dir, &dst) != 0;
        TND_TRY(tnd_mkdirs(dump_dir));
    }
    snprintf(path, sizeof path, "%s/timings.json", out);
    if (!(timings = fopen(path, "w"))) {
        res = tnd_fail(TND_ERR_IO, "denoise: %s: cannot create", path);
        goto fail;
    }
    fprintf(timings, "{\n  \"denoiser\": \"%s\",\n  \"device\": \"%s\",\n  \"frames\": [",
            dn_name, vk.info.name);
    int stopped = 0; /* interrupted (between frames: the ones written stay) */
    for (size_t i = 0; i < n && !(stopped = app_interrupted()); i++) {
        const char *name = pl_frontend_frame_name(rp, (uint32_t)i);
        rn_dump_ctx dc = {.mask = dump_mask, .dir = dump_dir};
        snprintf(dc.stem, sizeof dc.stem, "%s", name);
        char *dot = strrchr(dc.stem, '.');
        if (dot)
            *dot = '\0';
        TND_TRY(pl_frontend_set_frame(rp, NULL, NULL, (uint32_t)i, 0, 0));
        pl_step step = {.frame = {.reset = i == 0}, .frame_from_host = true, .yfov = yfov_deg,
                        .dt = 1.0f / 30, .after_backend = dump_mask ? rn_dump_after_backend : NULL,
                        .user = &dc};
        pl_step_result pr;
        TND_TRY(pl_chain_run(chain, rp, &step, rgb, display, &pr));
        fprintf(timings, "%s\n    {\"file\": \"%s\"", i ? "," : "", name);
        rn_timings_members(timings, chain, &pr); /* every pass of the chain */
        fputc('}', timings);
        snprintf(path, sizeof path, "%s/%s", out, name);
        TND_TRY(rn_write_rgb_exr(path, rgb, w, h));
        size_t l = strlen(path);
        memcpy(path + l - 4, ".png", 5);
        TND_TRY(rn_write_png(path, display, w, h));
        written = i + 1;
        app_progress_step(&bar, (unsigned)i + 1);
    }
    app_progress_end(&bar);
    if (stopped) /* (timings.json says where it stopped) */
        fprintf(timings, "\n  ],\n  \"interrupted\": {\"signal\": \"%s\", \"frames_written\": %zu}",
                rn_signal_name(stopped), written);
    fprintf(timings, "%s\n}\n", stopped ? "" : "\n  ]");
    if (fclose(timings) != 0) {
        timings = NULL;
        res = tnd_fail(TND_ERR_IO, "denoise: %s/timings.json: write failed", out);
        goto fail;
    }
    timings = NULL;
    if (vk.validation && tnd_vk_validation_errors(&vk)) {
        res = tnd_fail(TND_ERR_VULKAN, "%u Vulkan validation error(s)", tnd_vk_validation_errors(&vk));
        goto fail;
    }
    if (stopped) {
        fprintf(stderr, "%standem: denoise: interrupted (%s): %zu of %zu frames written in %s/\n",
                bar.enabled ? "\n" : "", rn_signal_name(stopped), written, n, out);
        status = app_interrupt_status();
        goto fail;
    }
    if (!app_quiet())
        fprintf(stderr, "tandem: denoise: %zu frame%s (%s) -> %s/\n", n, n == 1 ? "" : "s",
                dn_name, out);
    status = APP_EXIT_OK;
fail:
    if (status == APP_EXIT_FAIL)
        app_report("denoise", res);
    if (timings)
        fclose(timings);
    if (status == APP_EXIT_FAIL && begun) {
        if (dump_made)
            rn_remove_flat_dir(dump_dir);
        if (!out_existed) {
            rn_remove_flat_dir(out);
        } else { /* only this run's files */
            for (size_t i = 0; i < written + 1 && i < n; i++) {
                snprintf(path, sizeof path, "%s/%s", out, pl_frontend_frame_name(rp, (uint32_t)i));
                remove(path);
                memcpy(path + strlen(path) - 4, ".png", 5);
                remove(path);
            }
            snprintf(path, sizeof path, "%s/timings.json", out);
            remove(path);
        }
    }
    if (lock_fd >= 0 && (status != APP_EXIT_FAIL || out_existed))
        rn_unlock_dir(out, lock_fd);
    else if (lock_fd >= 0) /* (the directory itself is gone) */
        close(lock_fd);
    free(rgb);
    free(display);
    pl_chain_destroy(chain);
    if (vk.device || vk.instance)
        tnd_vk_destroy(&vk);
    pl_frontend_destroy(rp);
    tnd_capture_map_destroy(map);
    return status;
}
