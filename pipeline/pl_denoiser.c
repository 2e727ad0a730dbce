/* pipeline/pl_denoiser.c: the denoisers' registry (the list: pl_denoisers.h; the built-in
 * back-end's adapter: pl_dn_backend.c; plugins': pl_plugin.c). Each entry says what the
 * denoiser is: its name, its capabilities (PL_DN_*: re-shaded gradient
 * samples, filtering, the back-end's dumps), its parameters (one pl_param table: the command
 * line, run.json, the viewer's keys and states and the sweep's knobs are made from it) and the
 * passes it times. A new built-in denoiser is its adapter pipeline/pl_dn_NAME.c and one more line
 * in pl_denoisers.h (docs/extending.md).
 * Entry points: pl_denoiser_names, pl_denoiser_default, pl_denoiser_with, pl_denoiser_count,
 * pl_denoiser_at, pl_denoiser_cap_name, pl_denoiser_find, pl_denoiser_has_param, pl_denoiser_for,
 * pl_denoiser_other, pl_pass_all, pl_pass_owner_of, pl_pass_group_name, pl_param_count, pl_param_at, pl_param_find,
 * pl_param_set_put, pl_param_set_get, pl_param_key, pl_denoiser_ops_find. */
#include "pipeline/pl_internal.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---- the registry ------------------------------------------------------------------------- */
/* pl_denoisers.h lists them, one line each; the first is the commands' default */
#define PL_DENOISER(ops) extern const pl_denoiser_ops ops;
#include "pipeline/pl_denoisers.h"
#undef PL_DENOISER
#define PL_DENOISER(ops) &ops,
static const pl_denoiser_ops *const registry[] = {
#include "pipeline/pl_denoisers.h"
};
#undef PL_DENOISER
enum { REGISTERED = sizeof registry / sizeof registry[0] };

const char *pl_denoiser_names(void)
{
    static char names[256];
    if (!names[0])
        for (int i = 0; i < REGISTERED; i++)
            snprintf(names + strlen(names), sizeof names - strlen(names), "%s%s", i ? ", " : "",
                     registry[i]->info.name);
    return names;
}

const char *pl_denoiser_default(void)
{
    return registry[0]->info.name;
}

const pl_denoiser_info *pl_denoiser_with(uint32_t caps)
{
    for (int i = 0; i < REGISTERED; i++)
        if ((registry[i]->info.caps & caps) == caps)
            return &registry[i]->info;
    return NULL;
}

uint32_t pl_denoiser_count(void)
{
    return REGISTERED;
}

const pl_denoiser_info *pl_denoiser_at(uint32_t i)
{
    return i < REGISTERED ? &registry[i]->info : NULL;
}

const pl_denoiser_ops *pl_denoiser_ops_find(const char *name)
{
    if (strncmp(name, "plugin:", 7) == 0)
        return name[7] ? &pl_plugin_denoiser_ops : NULL;
    if (strncmp(name, "python:", 7) == 0)
        return name[7] ? &pl_python_denoiser_ops : NULL;
    for (int i = 0; i < REGISTERED; i++)
        if (strcmp(registry[i]->info.name, name) == 0)
            return registry[i];
    return NULL;
}

tnd_result pl_denoiser_find(const char *name, const pl_denoiser_info **info)
{
    const pl_denoiser_ops *ops = pl_denoiser_ops_find(name);
    *info = ops ? &ops->info : NULL;
    if (!ops)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "denoiser '%s' (expected %s, plugin:PATH.so or "
                                                  "python:MODULE:CALLABLE)",
                        name, pl_denoiser_names());
    return TND_OK;
}

const char *pl_denoiser_cap_name(uint32_t bit)
{
    /* in PL_DN_* order */
    static const char *const names[] = {"gradients",  "filters",  "dumps",       "plugin",
                                        "confidence", "spec_hit", "diffuse_view"};
    _Static_assert(1u << (sizeof names / sizeof *names - 1) == PL_DN_DIFFUSE_VIEW,
                   "one name a bit");
    return bit < sizeof names / sizeof *names ? names[bit] : NULL;
}

bool pl_denoiser_has_param(const pl_denoiser_info *d, const char *name)
{
    for (uint32_t i = 0; i < d->nparams; i++)
        if (strcmp(d->params[i]->name, name) == 0)
            return true;
    return false;
}

const pl_denoiser_info *pl_denoiser_for(const pl_denoiser_info *d, uint32_t fe_caps)
{
    const pl_denoiser_ops *fb;
    if ((d->caps & PL_DN_GRADIENTS) && !(fe_caps & PL_CAP_RESHADE) && d->fallback &&
        (fb = pl_denoiser_ops_find(d->fallback)))
        return &fb->info;
    return d;
}

const pl_denoiser_info *pl_denoiser_other(const pl_denoiser_info *d)
{
    const pl_denoiser_info *fb = NULL;
    if (d->fallback && pl_denoiser_find(d->fallback, &fb) == TND_OK)
        return fb;
    for (uint32_t i = 0; i < pl_denoiser_count(); i++) {
        const pl_denoiser_info *e = pl_denoiser_at(i);
        if (e->fallback && strcmp(e->fallback, d->name) == 0)
            return e;
    }
    for (uint32_t i = 0; i < pl_denoiser_count(); i++) {
        const pl_denoiser_info *e = pl_denoiser_at(i);
        if ((e->caps & PL_DN_FILTERS) && !(e->caps & PL_DN_GRADIENTS) && e != d)
            return e;
    }
    return d;
}

/* ---- passes ------------------------------------------------------------------------------ */
const char *pl_pass_group_name(pl_pass_group g)
{
    static const char *const names[PL_GROUPS] = {"front-end", "gradients", "back-end", "post"};
    return g < PL_GROUPS ? names[g] : "?";
}

static void add_passes(const pl_pass *p, uint32_t n, const pl_pass **out, uint32_t max,
                       uint32_t *count)
{
    for (uint32_t i = 0; i < n; i++) {
        bool seen = false;
        for (uint32_t k = 0; k < *count && k < max; k++)
            seen = seen || strcmp(out[k]->key, p[i].key) == 0;
        if (!seen && *count < max)
            out[(*count)++] = &p[i];
    }
}

uint32_t pl_pass_all(const pl_pass **out, uint32_t max)
{
    uint32_t n = 0;
    add_passes(pl_frontend_passes, pl_frontend_pass_count, out, max, &n);
    for (int i = 0; i < REGISTERED; i++)
        add_passes(registry[i]->info.passes, registry[i]->info.npasses, out, max, &n);
    add_passes(pl_plugin_denoiser_ops.info.passes, pl_plugin_denoiser_ops.info.npasses, out, max,
               &n);
    add_passes(pl_python_denoiser_ops.info.passes, pl_python_denoiser_ops.info.npasses, out, max,
               &n);
    add_passes(pl_post_passes, pl_post_pass_count, out, max, &n);
    return n;
}

pl_pass_owner pl_pass_owner_of(const pl_pass *p)
{
    for (uint32_t i = 0; i < pl_frontend_pass_count; i++)
        if (p == &pl_frontend_passes[i])
            return PL_OWNER_FRONTEND;
    for (uint32_t i = 0; i < pl_post_pass_count; i++)
        if (p == &pl_post_passes[i])
            return PL_OWNER_POST;
    return PL_OWNER_DENOISER;
}

/* ---- parameters -------------------------------------------------------------------------- */
/* every registered denoiser's parameters, each name once (made once: the registry is const) */
static uint32_t params_all(const pl_param ***list)
{
    static const pl_param *all[PL_PARAMS_MAX];
    static uint32_t n;
    static bool made;
    *list = all;
    if (made)
        return n;
    made = true;
    const pl_param **out = all;
    for (int i = 0; i < REGISTERED; i++)
        for (uint32_t k = 0; k < registry[i]->info.nparams; k++) {
            const pl_param *p = registry[i]->info.params[k];
            bool seen = false;
            for (uint32_t j = 0; j < n; j++)
                seen = seen || strcmp(out[j]->name, p->name) == 0;
            if (!seen && n < PL_PARAMS_MAX)
                out[n++] = p;
        }
    return n;
}

uint32_t pl_param_count(void)
{
    const pl_param **all;
    return params_all(&all);
}

const pl_param *pl_param_at(uint32_t i)
{
    const pl_param **all;
    return i < params_all(&all) ? all[i] : NULL;
}

const pl_param *pl_param_find(const char *name)
{
    const pl_param **all;
    uint32_t n = params_all(&all);
    for (uint32_t i = 0; i < n; i++)
        if (strcmp(all[i]->name, name) == 0)
            return all[i];
    return NULL;
}

const char *pl_param_key(const pl_param *p, char *buf, size_t cap)
{
    snprintf(buf, cap, "%s", p->name);
    for (char *c = buf; *c; c++)
        if (*c == '-')
            *c = '_';
    return buf;
}

tnd_result pl_param_set_put(pl_param_set *s, const char *name, double v)
{
    const pl_param *p = pl_param_find(name);
    if (!p)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "no denoiser has a parameter '%s'", name);
    bool ok = isfinite(v) && (v == 0 || ((p->min_open ? v > p->min : v >= p->min) && v <= p->max &&
                                         (p->kind != PL_PARAM_UINT || v == floor(v))));
    if (!ok)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "--%s %g: expected %s in %c%g, %g]", p->name, v,
                        p->kind == PL_PARAM_UINT ? "a whole number" : "a value",
                        p->min_open ? '(' : '[', p->min, p->max);
    uint32_t i = 0;
    while (i < s->n && s->param[i] != p)
        i++;
    if (v == 0) { /* the default again */
        if (i < s->n) {
            memmove(&s->param[i], &s->param[i + 1], (s->n - i - 1) * sizeof *s->param);
            memmove(&s->value[i], &s->value[i + 1], (s->n - i - 1) * sizeof *s->value);
            s->n--;
        }
        return TND_OK;
    }
    if (i == s->n) {
        if (s->n == PL_PARAMS_MAX)
            return tnd_fail(TND_ERR_INVALID_ARGUMENT, "more than %d parameters", PL_PARAMS_MAX);
        s->param[s->n++] = p;
    }
    s->value[i] = v;
    return TND_OK;
}

double pl_param_set_get(const pl_param_set *s, const char *name)
{
    for (uint32_t i = 0; i < s->n; i++)
        if (strcmp(s->param[i]->name, name) == 0)
            return s->value[i];
    return 0.0;
}
