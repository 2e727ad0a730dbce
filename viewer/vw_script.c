/* viewer/vw_script.c: a scripted session (--script FILE, docs/viewer.md): timed key, mouse and
 * resize events, screenshots, waits for a file and the exit, read and played frame by frame: how
 * the tests drive the window under Xvfb. */
#include "viewer/vw_internal.h"

#include <cjson/cJSON.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

/* ---- the script -------------------------------------------------------------------------------- */
tnd_result vw_load_script(const char *path, vw_script_event **out, uint32_t *count)
{
    tnd_result res = TND_OK;
    void *buf = NULL;
    size_t n = 0;
    *out = NULL;
    *count = 0;
    TND_TRY_RETURN(tnd_file_read(path, &buf, &n));
    cJSON *j = cJSON_ParseWithLength(buf, n), *e;
    free(buf);
    const cJSON *evs = cJSON_GetObjectItem(j, "events");
    if (!j || !cJSON_IsArray(evs)) {
        cJSON_Delete(j);
        return tnd_fail(TND_ERR_BAD_INPUT, "view script %s: {\"events\": [...]} expected", path);
    }
    vw_script_event *ev = calloc((size_t)cJSON_GetArraySize(evs) + 1, sizeof *ev);
    if (!ev) {
        cJSON_Delete(j);
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "view: out of memory");
    }
    uint32_t k = 0;
    cJSON_ArrayForEach(e, evs)
    {
        vw_script_event s = {0};
        const cJSON *f = cJSON_GetObjectItem(e, "frame"), *key = cJSON_GetObjectItem(e, "key");
        const cJSON *mouse = cJSON_GetObjectItem(e, "mouse"), *rs = cJSON_GetObjectItem(e, "resize");
        if (!cJSON_IsNumber(f) || f->valuedouble < 0 || (k && f->valuedouble < ev[k - 1].frame)) {
            res = tnd_fail(TND_ERR_BAD_INPUT,
                           "view script %s: event %u: \"frame\" (frames shown so far, in order) "
                           "expected", path, k);
            goto fail;
        }
        s.frame = (uint32_t)f->valuedouble;
        if (cJSON_IsString(key)) {
            s.key = vw_key_code(key->valuestring);
            if (s.key < 0) {
                res = tnd_fail(TND_ERR_BAD_INPUT, "view script %s: event %u: key \"%s\" unknown",
                               path, k, key->valuestring);
                goto fail;
            }
            const cJSON *down = cJSON_GetObjectItem(e, "down");
            s.kind = down ? EV_KEY : EV_TAP;
            s.down = cJSON_IsTrue(down);
        } else if (cJSON_GetArraySize(mouse) == 2) {
            s.kind = EV_MOUSE;
            s.dx = cJSON_GetArrayItem(mouse, 0)->valuedouble;
            s.dy = cJSON_GetArrayItem(mouse, 1)->valuedouble;
            s.drag = !cJSON_IsFalse(cJSON_GetObjectItem(e, "drag"));
        } else if (cJSON_GetArraySize(rs) == 2 && cJSON_GetArrayItem(rs, 0)->valuedouble >= 16 &&
                   cJSON_GetArrayItem(rs, 1)->valuedouble >= 16) {
            s.kind = EV_RESIZE;
            s.w = (uint32_t)cJSON_GetArrayItem(rs, 0)->valuedouble;
            s.h = (uint32_t)cJSON_GetArrayItem(rs, 1)->valuedouble;
        } else if (cJSON_IsTrue(cJSON_GetObjectItem(e, "screenshot"))) {
            s.kind = EV_SHOT;
        } else if (cJSON_IsTrue(cJSON_GetObjectItem(e, "exit"))) {
            s.kind = EV_EXIT;
        } else if (cJSON_IsString(cJSON_GetObjectItem(e, "wait_for")) &&
                   strlen(cJSON_GetObjectItem(e, "wait_for")->valuestring) < sizeof s.path) {
            s.kind = EV_WAIT;
            strcpy(s.path, cJSON_GetObjectItem(e, "wait_for")->valuestring);
        } else {
            res = tnd_fail(TND_ERR_BAD_INPUT,
                           "view script %s: event %u: one of key, mouse [dx, dy], resize [w, h] "
                           "(16 or more), screenshot, wait_for (a file) or exit expected", path,
                           k);
            goto fail;
        }
        ev[k++] = s;
    }
    *out = ev;
    *count = k;
    ev = NULL;
fail:
    free(ev);
    cJSON_Delete(j);
    return res;
}

/* Apply the script's events of this frame; a resize waits (2 s at most) for the window. */
tnd_result vw_play(viewer *v, const vw_script_event *ev, uint32_t n, uint32_t *next)
{
    while (*next < n && ev[*next].frame <= v->steps) {
        const vw_script_event *e = &ev[(*next)++];
        switch (e->kind) {
        case EV_KEY: vw_on_key(v, e->key, e->down); break;
        case EV_TAP:
            vw_on_key(v, e->key, true);
            vw_on_key(v, e->key, false);
            break;
        case EV_MOUSE:
            vw_on_event(&(vw_event){.kind = VW_MOUSE, .dx = e->dx, .dy = e->dy, .drag = e->drag}, v);
            break;
        case EV_RESIZE: {
            vw_window_set_size(v->win, e->w, e->h);
            double t0 = tnd_now();
            uint32_t w = 0, h = 0;
            while (tnd_now() - t0 < 2.0) {
                vw_window_poll(v->win);
                vw_window_size(v->win, &w, &h);
                if (w == e->w && h == e->h)
                    break;
            }
            if (w != e->w || h != e->h)
                return tnd_fail(TND_ERR_UNSUPPORTED,
                                "view: the window system kept the window at %ux%u (asked %ux%u)",
                                w, h, e->w, e->h);
            v->rebuild = true;
            break;
        }
        case EV_SHOT: v->want_shot = true; break;
        case EV_WAIT: { /* until another process made the file (30 s at most) */
            double t0 = tnd_now();
            FILE *fp = NULL;
            while (!(fp = fopen(e->path, "rb")) && tnd_now() - t0 < 30.0) {
                vw_window_poll(v->win);
                struct timespec ts = {0, 20 * 1000 * 1000};
                nanosleep(&ts, NULL);
            }
            if (!fp)
                return tnd_fail(TND_ERR_IO, "view: script: %s did not appear in 30 s", e->path);
            fclose(fp);
            break;
        }
        case EV_EXIT: v->quit = true; break;
        }
    }
    return TND_OK;
}
