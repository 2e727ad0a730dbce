/* tests/install/denoise_capture.c: a program outside Tandem's tree, built against the installed
 * libtandem (tests/test_install.sh): a capture through the pipeline as `tandem denoise
 * --denoiser svgf` runs it (capture replay as the front-end, the back-end, TAA, auto exposure),
 * each frame's linear HDR output written as OUT/frame_NNNN.exr.
 *     denoise_capture CAPTURES OUT */
#include <tandem/tandem.h>

#include <stdio.h>
#include <stdlib.h>

static int fail(tnd_result r)
{
    fprintf(stderr, "denoise_capture: %s: %s\n", tnd_result_message(r), tnd_error_detail());
    return 1;
}

int main(int argc, char **argv)
{
    if (argc != 3) {
        fprintf(stderr, "usage: denoise_capture CAPTURES OUT\n");
        return 2;
    }
    tnd_vk vk = {0};
    pl_frontend *replay = NULL;
    pl_chain *chain = NULL;
    float *rgb = NULL;
    int status = 1;
    tnd_result r;
    if ((r = tnd_vk_create(&(tnd_vk_desc){.no_ray_tracing = true}, &vk)) != TND_OK ||
        (r = pl_frontend_create("replay", NULL, &(pl_frontend_desc){.captures = argv[1]},
                                &replay)) != TND_OK) {
        status = fail(r);
        goto done;
    }
    uint32_t w = 0, h = 0;
    tnd_precision precision = TND_PRECISION_F32;
    bool split = false;
    pl_frontend_recorded(replay, &w, &h, &precision, &split);
    pl_chain_desc cd = {.vk = &vk, .width = w, .height = h, .precision = precision,
                        .backend = true, .denoiser = "svgf",
                        .post = {.taa = true, .interleave = split}};
    if ((r = pl_chain_create(&cd, &chain)) != TND_OK || (r = tnd_mkdirs(argv[2])) != TND_OK) {
        status = fail(r);
        goto done;
    }
    if (!(rgb = malloc((size_t)w * h * 3 * sizeof *rgb)))
        goto done;
    for (uint32_t i = 0; i < pl_frontend_length(replay); i++) {
        pl_step step = {.frame = {.reset = i == 0}, .frame_from_host = true, .yfov = 40.0,
                        .dt = 1.0f / 30};
        char path[4096];
        snprintf(path, sizeof path, "%s/%s", argv[2], pl_frontend_frame_name(replay, i));
        const tnd_exr_channel_desc ch[3] = {{"R", TND_EXR_FLOAT, rgb, 3},
                                            {"G", TND_EXR_FLOAT, rgb + 1, 3},
                                            {"B", TND_EXR_FLOAT, rgb + 2, 3}};
        if ((r = pl_frontend_set_frame(replay, NULL, NULL, i, 0, 0)) != TND_OK ||
            (r = pl_chain_run(chain, replay, &step, rgb, NULL, NULL)) != TND_OK ||
            (r = tnd_exr_write(path, w, h, ch, 3, NULL, 0, TND_EXR_ZIP)) != TND_OK) {
            status = fail(r);
            goto done;
        }
    }
    if (vk.validation && tnd_vk_validation_errors(&vk)) { /* ($TANDEM_VALIDATION=1) */
        fprintf(stderr, "denoise_capture: %u Vulkan validation errors\n",
                tnd_vk_validation_errors(&vk));
        goto done;
    }
    printf("denoise_capture: %u frames of %ux%u -> %s\n", pl_frontend_length(replay), w, h,
           argv[2]);
    status = 0;
done:
    free(rgb);
    pl_chain_destroy(chain);
    pl_frontend_destroy(replay);
    tnd_vk_destroy(&vk);
    return status;
}
