/* app/cmd_view.c: `tandem view`: the pipeline live in a window (viewer/, vw_view_run): its
 * options, and what it prints (the soak's figures). */
#include "app/app.h"
#include "viewer/viewer.h"

#include <cjson/cJSON.h>
#include <stdlib.h>

#ifndef TND_DATA_DIR
#define TND_DATA_DIR "data"
#endif

static const app_cmd view_cmd = {
    "view",
    "The pipeline live in a window: fly the camera (WASD, Q/E down/up, drag to look; shift\n"
    "faster, control slower), change the knobs (1/2/3/4/5 the registered denoisers in order\n"
    "(asvgf/svgf/off/recurrent), then the denoiser plugin, F front-end (the registered ones,\n"
    "then the front-end plugin), [ ] bounces (0, half, 1, 2, ...), P precision, T TAA, K\n"
    "tone curve, B bloom, U render scale (1, 0.67, 0.5: traced smaller, upscaled; the views\n"
    "and the reference need 1), the\n"
    "denoiser's parameters on their keys (, . a-trous iterations, M minimum alpha, G antilag\n"
    "gain, H recurrent's fast history, C its clamp: the overlay lists them), - = exposure bias, 7 8 environment rotation, 9 0 its intensity), V cycles\n"
    "the views (final, contract entries, back-end dumps), TAB the splits (noisy | denoised,\n"
    "denoiser A | B, front-end A | B), R a progressive reference of a still camera, X the\n"
    "relative error, then FLIP, against that reference, O the\n"
    "overlay, F12 writes a screenshot (PNG, EXR and its repro state for `tandem render\n"
    "--view`), F11 the next frame's capture, F5 reloads the shaders from $TANDEM_SHADER_DIR\n"
    "(scripts/compile-shaders.sh), ESC quits.",
    "[--scene PATH] [--frontend NAME] [--denoiser NAME] [--size WxH] [--state FILE] "
    "[--script FILE] [--out DIR]",
    NULL};

int cmd_view(int argc, char **argv)
{
    const char *scene = TND_DATA_DIR "/scenes/cornell.gltf", *frontend = "vk",
               *denoiser = pl_denoiser_default(), *state = NULL, *script = NULL, *out = ".";
    unsigned size[2] = {640, 360}, frames = 0;
    bool soak = false, json = false;
    rn_env env = RN_ENV_INIT;
    char fe_help[200], dn_help[300];
    snprintf(fe_help, sizeof fe_help, "the front-end: %s (default vk)", pl_frontend_live_names());
    snprintf(dn_help, sizeof dn_help,
             "the denoiser: %s, plugin:PATH.so or python:MODULE:CALLABLE (default %s)",
             pl_denoiser_names(), pl_denoiser_default());
    const app_opt opts[] = {
        {"scene", APP_OPT_STRING, &scene, "PATH", "glTF scene (default: cornell)"},
        {"frontend", APP_OPT_STRING, &frontend, "NAME", fe_help},
        {"denoiser", APP_OPT_STRING, &denoiser, "NAME", dn_help},
        {"size", APP_OPT_SIZE, size, "WxH", "window size (default 640x360)"},
        {"state", APP_OPT_STRING, &state, "FILE",
         "start from a repro state (a screenshot's .json)"},
        {"script", APP_OPT_STRING, &script, "FILE",
         "play timed key, mouse and resize events, then exit (docs/viewer.md)"},
        {"frames", APP_OPT_UINT, &frames, "N", "exit after N frames (default: when closed)"},
        {"soak", APP_OPT_FLAG, &soak, NULL,
         "with --frames N: sample memory, descriptors and device allocations over the viewer's "
         "loop and print whether they stay flat, as bench --soak does (docs/reliability.md)"},
        {"json", APP_OPT_FLAG, &json, NULL, "--soak's figures as JSON, with every sample"},
        {"out", APP_OPT_STRING, &out, "DIR", "where screenshots and captures go (default .)"},
        APP_ENV_OPTS(&env),
        {0},
    };
    const char *pos[1];
    int npos;
    int rc = app_parse(&view_cmd, opts, argc, argv, pos, 0, &npos);
    if (rc >= 0)
        return rc;
    if (soak && !frames) {
        fprintf(stderr, "tandem view: --soak needs --frames N (the frames it judges)\n");
        return APP_EXIT_USAGE;
    }
    rn_host h = app_host();
    vw_view_result r;
    tnd_result res = vw_view_run(&(vw_view_opts){.scene = scene, .frontend = frontend,
                                                 .denoiser = denoiser, .state = state,
                                                 .script = script, .out = out,
                                                 .size = {size[0], size[1]}, .frames = frames,
                                                 .soak = soak, .env = env},
                                 &h, &r);
    if (r.soak && json) {
        cJSON *root = cJSON_CreateObject(), *runs = cJSON_AddArrayToObject(root, "runs");
        cJSON_AddStringToObject(root, "scene", r.scene);
        cJSON_AddNumberToObject(root, "frames", r.steps);
        cJSON_AddNumberToObject(root, "width", r.size[0]);
        cJSON_AddNumberToObject(root, "height", r.size[1]);
        cJSON *row = rn_soak_rec_json(r.soak);
        cJSON_AddBoolToObject(root, "flat", cJSON_IsTrue(cJSON_GetObjectItem(row, "flat")));
        cJSON_AddItemToArray(runs, row);
        char *t = cJSON_Print(root);
        printf("%s\n", t ? t : "{}");
        free(t);
        cJSON_Delete(root);
    } else if (r.soak) {
        app_soak_print(r.soak, "in the viewer's loop", r.scene, r.size);
    }
    rn_soak_rec_free(r.soak);
    return app_finish("view", res);
}
