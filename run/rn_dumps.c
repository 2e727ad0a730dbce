/* run/rn_dumps.c: --dump LIST for render and denoise: the back-end's buffers after each frame as
 * EXR files DIR/NAME_STEM.exr (4 named float channels; STEM: the frame number or input name).
 * Entry points: rn_dump_parse, rn_dumps_write, rn_dump_after_backend. */
#include "run/rn_internal.h"
#include "denoise/denoise.h"

#include <stdlib.h>
#include <string.h>

/* --dump LIST: a bit per dn_dump index */
tnd_result rn_dump_parse(const char *list, uint32_t *mask)
{
    *mask = 0;
    if (!list)
        return TND_OK;
    const char *p = list;
    while (*p) {
        size_t n = strcspn(p, ",");
        bool found = false;
        if (n == 3 && strncmp(p, "all", 3) == 0) {
            *mask = (1u << dn_dump_count()) - 1u;
            found = true;
        }
        for (uint32_t i = 0; !found && i < dn_dump_count(); i++) {
            const char *name = dn_dump_name(i, NULL);
            if (strlen(name) == n && strncmp(p, name, n) == 0) {
                *mask |= 1u << i;
                found = true;
            }
        }
        if (!found)
            return tnd_fail(TND_ERR_INVALID_ARGUMENT,
                            "--dump: unknown buffer '%.*s' (see --help)", (int)n, p);
        p += n;
        if (*p == ',')
            p++;
    }
    return TND_OK;
}

tnd_result rn_dumps_write(dn_context *dn, uint32_t mask, const char *dir, const char *stem)
{
    tnd_result res = TND_OK;
    float *px = NULL;
    for (uint32_t i = 0; res == TND_OK && i < dn_dump_count(); i++) {
        if (!(mask & (1u << i)))
            continue;
        uint32_t w = 0, h = 0;
        const char *ch[4];
        const char *name = dn_dump_name(i, ch);
        TND_TRY(dn_dump_size(dn, i, &w, &h));
        free(px);
        px = malloc((size_t)w * h * 16);
        if (!px) {
            res = tnd_fail(TND_ERR_OUT_OF_MEMORY, "dump: out of memory");
            goto fail;
        }
        TND_TRY(dn_dump(dn, i, px));
        char path[4200];
        snprintf(path, sizeof path, "%s/%s_%s.exr", dir, name, stem);
        const tnd_exr_channel_desc cd[4] = {{ch[0], TND_EXR_FLOAT, px, 4},
                                            {ch[1], TND_EXR_FLOAT, px + 1, 4},
                                            {ch[2], TND_EXR_FLOAT, px + 2, 4},
                                            {ch[3], TND_EXR_FLOAT, px + 3, 4}};
        TND_TRY(tnd_exr_write(path, w, h, cd, 4, NULL, 0, TND_EXR_ZIP));
    }
fail:
    free(px);
    return res;
}

tnd_result rn_dump_after_backend(dn_context *dn, void *user)
{
    const rn_dump_ctx *d = user;
    return rn_dumps_write(dn, d->mask, d->dir, d->stem);
}
