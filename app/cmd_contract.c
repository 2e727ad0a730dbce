/* app/cmd_contract.c: `tandem contract`: the buffer contract table (Markdown, or JSON). */
#include "app/app.h"

#include <cjson/cJSON.h>
#include <stdlib.h>

static const app_cmd contract_cmd = {
    "contract", "Print the buffer contract: every entry, its EXR channels, formats and meaning.",
    "[--json]", NULL};

int cmd_contract(int argc, char **argv)
{
    bool json = false;
    const app_opt opts[] = {
        {"json", APP_OPT_FLAG, &json, NULL, "print the table as JSON instead of Markdown"},
        {0},
    };
    const char *pos[1];
    int npos;
    int rc = app_parse(&contract_cmd, opts, argc, argv, pos, 0, &npos);
    if (rc >= 0)
        return rc;
    if (!json) {
        size_t n = tnd_ct_markdown(NULL, 0);
        char *buf = malloc(n + 1);
        if (!buf)
            return app_report("contract", TND_ERR_OUT_OF_MEMORY);
        tnd_ct_markdown(buf, n + 1);
        fputs(buf, stdout);
        free(buf);
        return APP_EXIT_OK;
    }
    cJSON *root = cJSON_CreateObject();
    cJSON_AddNumberToObject(root, "contract_version", TND_CONTRACT_VERSION);
    cJSON_AddNumberToObject(root, "depth_miss", TND_DEPTH_MISS);
    cJSON *arr = cJSON_AddArrayToObject(root, "entries");
    for (int i = 0; i < TND_CT_COUNT; i++) {
        const tnd_ct_info *e = tnd_ct_get((tnd_ct)i);
        cJSON *o = cJSON_CreateObject();
        cJSON_AddStringToObject(o, "name", e->name);
        cJSON_AddNumberToObject(o, "binding", i);
        cJSON *ch = cJSON_AddArrayToObject(o, "exr_channels");
        for (uint32_t c = 0; c < e->comps; c++) {
            char nm[64];
            tnd_ct_exr_name((tnd_ct)i, c, nm, sizeof nm);
            cJSON_AddItemToArray(ch, cJSON_CreateString(nm));
        }
        cJSON_AddStringToObject(o, "type", e->kind == TND_CT_UINT ? "uint32" : "float");
        cJSON_AddStringToObject(o, "glsl_float32", e->glsl_f32);
        cJSON_AddStringToObject(o, "glsl_packed", e->glsl_packed);
        cJSON_AddStringToObject(o, "need",
                                e->need == TND_NEED_REQUIRED  ? "required"
                                : e->need == TND_NEED_DERIVED ? "derived"
                                                              : "default");
        cJSON_AddNumberToObject(o, "default", e->default_value);
        cJSON_AddStringToObject(o, "semantic", e->semantic);
        cJSON_AddStringToObject(o, "unit", e->unit);
        cJSON_AddStringToObject(o, "space", e->space);
        cJSON_AddItemToArray(arr, o);
    }
    char *s = cJSON_Print(root);
    printf("%s\n", s);
    free(s);
    cJSON_Delete(root);
    return APP_EXIT_OK;
}
