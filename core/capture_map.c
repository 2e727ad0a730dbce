/* core/capture_map.c: other renderers' EXR captures read through a JSON mapping
 * (docs/captures.md): which files hold a frame, which channels feed which contract entry with
 * which conversions, where the camera comes from (for camera-space data and for motion
 * reconstructed from positions), which way the world's up axis points and what a motion vector
 * means.
 * Matrices: Tandem's column-major (m[col * 4 + row]); pbrt's header matrices are row-major
 * (M[i][j] at a[4i + j]) and are transposed on reading.
 * Entry points: tnd_capture_map_load/destroy/name/source, tnd_capture_map_list,
 * tnd_capture_read_mapped. */
#include "core/capture_internal.h"

#include <cjson/cJSON.h>
#include <ctype.h>
#include <dirent.h>
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#define MAP_ALTS  4
#define MAP_FILES 16

enum { MV_PIXELS = 0, MV_UV, MV_NDC };
enum { CAM_NONE = 0, CAM_PBRT, CAM_MITSUBA_FILE };

typedef struct map_entry {
    bool fed;
    int file; /* the role (map->role) of the file its channels are in */
    /* per component: up to MAP_ALTS candidate channel names (first found wins); none = constant */
    char chan[4][MAP_ALTS][128];
    int alts[4];
    uint32_t nchan; /* channels listed: the entry's components, or 3 for depth from a vector */
    float scale[4], offset[4];
    bool normalize;
    bool planar_to_distance;
    bool length;       /* depth: the length of a camera-space point (pbrt's P) */
    bool camera_space; /* normals, position: in the renderer's camera space */
    bool face_camera;  /* normals: flipped to face the primary ray */
    bool reconstruct;  /* motion: from the position and this frame's and the last frame's camera */
    float miss_at;     /* depth: values >= this (and <= 0) mean "no hit"; 0 = only non-positive */
    int divide_by;     /* contract entry or -1 */
    int subtract;  /* contract entry or -1: taken off before divide_by (emission out of radiance) */
    bool on_miss;  /* where depth is a miss the entry reads miss_chan instead (the background) */
    int miss_file; /* the role of the file miss_chan are in */
    char miss_chan[4][MAP_ALTS][128];
    int miss_alts[4];
    uint32_t nzero; /* depth: a miss where all these channels are 0 (OIDN's normal) */
    char zero_chan[4][MAP_ALTS][128];
    int zero_alts[4];
    /* motion: what the vector means (converted to previous - current, pixels, y down) */
    bool mv_negate, mv_y_up;
    int mv_unit;
    /* "optional": "what happens without it": where the file lacks the entry's channels, the
     * entry keeps its default and the frame says so (tnd_frame.fallback) */
    char fallback[200];
} map_entry;

struct tnd_capture_map {
    char path[1024];
    char name[256];
    char prefix[128];
    float xfov, yfov; /* radians, 0 = unknown */
    /* the files of a frame: role names and patterns ('*': anything, '{frame}': the frame's key);
     * role 0 is the primary file, by which frames are found */
    int nfiles;
    char role[MAP_FILES][32];
    char pattern[MAP_FILES][256];
    bool z_up; /* the renderer's world has +Z up: rotated into Tandem's +Y up */
    int camera;
    char cam_file[256];   /* CAM_MITSUBA_FILE: in the capture's directory */
    char cam_attr[2][64]; /* CAM_PBRT: world-to-camera and world-to-NDC attribute names */
    map_entry e[TND_CT_COUNT];
};

static tnd_result map_error(const char *path, const char *what)
{
    return tnd_fail(TND_ERR_BAD_INPUT, "mapping: %s: %s", path, what);
}

/* A JSON number that becomes a float: finite and representable (a mapping's 1e39 or a number
 * cJSON read as inf would turn every value it touches into inf or NaN). */
static bool float_item(const cJSON *n, float *out)
{
    if (!cJSON_IsNumber(n) || !isfinite(n->valuedouble) || fabs(n->valuedouble) > FLT_MAX)
        return false;
    *out = (float)n->valuedouble;
    return true;
}

/* ---- file patterns -------------------------------------------------------------------------- */
/* Does `name` match `pat` ('*' any run, '{frame}' a non-empty run captured into key)? */
static bool pattern_match(const char *pat, const char *name, char *key, size_t cap)
{
    if (!*pat)
        return !*name;
    if (*pat == '*') {
        for (const char *s = name;; s++) {
            if (pattern_match(pat + 1, s, key, cap))
                return true;
            if (!*s)
                return false;
        }
    }
    if (strncmp(pat, "{frame}", 7) == 0) {
        for (const char *s = name + 1; s <= name + strlen(name); s++) {
            if ((!key || (size_t)(s - name) < cap) && pattern_match(pat + 7, s, NULL, 0)) {
                if (key) {
                    memcpy(key, name, (size_t)(s - name));
                    key[s - name] = '\0';
                }
                return true;
            }
        }
        return false;
    }
    return *pat == *name && pattern_match(pat + 1, name + 1, key, cap);
}

/* Natural order: runs of digits compare as numbers ("f9" before "f10"). */
static int natural_cmp(const void *pa, const void *pb)
{
    const char *a = *(char *const *)pa, *b = *(char *const *)pb;
    while (*a && *b) {
        if (isdigit((unsigned char)*a) && isdigit((unsigned char)*b)) {
            while (*a == '0')
                a++;
            while (*b == '0')
                b++;
            size_t la = 0, lb = 0;
            while (isdigit((unsigned char)a[la]))
                la++;
            while (isdigit((unsigned char)b[lb]))
                lb++;
            if (la != lb)
                return la < lb ? -1 : 1;
            int c = strncmp(a, b, la);
            if (c)
                return c;
            a += la, b += lb;
        } else {
            if (*a != *b)
                return (unsigned char)*a < (unsigned char)*b ? -1 : 1;
            a++, b++;
        }
    }
    return *a ? 1 : *b ? -1 : 0;
}

void tnd_capture_dir(const char *captures, char *dir, size_t cap)
{
    struct stat st;
    snprintf(dir, cap, "%s/capture", captures);
    if (stat(dir, &st) != 0 || !S_ISDIR(st.st_mode))
        snprintf(dir, cap, "%s", captures);
}

void tnd_capture_list_free(char **names, size_t count)
{
    for (size_t i = 0; i < count; i++)
        free(names[i]);
    free(names);
}

tnd_result tnd_capture_check_entries(const tnd_frame *first, const tnd_frame *f, const char *path)
{
    for (int e = 0; e < TND_CT_COUNT; e++)
        if (first->present[e] != f->present[e])
            return tnd_fail(TND_ERR_BAD_INPUT,
                            "capture: %s: entry '%s' is %s here but %s in the sequence's first "
                            "frame (every frame must carry the same entries)",
                            path, tnd_ct_get((tnd_ct)e)->name, f->present[e] ? "present" : "absent",
                            first->present[e] ? "present" : "absent");
    return TND_OK;
}

tnd_result tnd_capture_map_list(const tnd_capture_map *map, const char *dir, char ***names,
                                size_t *count)
{
    static const char tandem_pattern[] = "frame_{frame}.exr";
    const char *pattern = map ? map->pattern[0] : tandem_pattern;
    *names = NULL;
    *count = 0;
    DIR *d = opendir(dir);
    if (!d)
        return tnd_fail(TND_ERR_IO, "%s: cannot open directory", dir);
    char **v = NULL;
    size_t n = 0;
    for (struct dirent *e; (e = readdir(d));) {
        if (e->d_name[0] == '.' || tnd_capture_is_gradients_file(e->d_name) ||
            !pattern_match(pattern, e->d_name, NULL, 0))
            continue;
        char **nv = realloc(v, (n + 1) * sizeof *nv);
        if (nv)
            v = nv;
        if (!nv || !(v[n] = strdup(e->d_name))) {
            for (size_t i = 0; i < n; i++)
                free(v[i]);
            free(v);
            closedir(d);
            return tnd_fail(TND_ERR_OUT_OF_MEMORY, "%s: out of memory", dir);
        }
        n++;
    }
    closedir(d);
    if (n == 0) {
        free(v);
        return map ? tnd_fail(TND_ERR_BAD_INPUT, "%s: no files match '%s' (mapping %s)", dir,
                              pattern, map->name)
                   : tnd_fail(TND_ERR_BAD_INPUT, "%s: no frame_NNNN.exr files", dir);
    }
    qsort(v, n, sizeof *v, natural_cmp);
    *names = v;
    *count = n;
    return TND_OK;
}

/* The file of role r for the frame whose key is `key`, in `dir`: exactly one must match. */
static tnd_result role_file(const tnd_capture_map *map, int r, const char *dir, const char *key,
                            const char *primary, char *out, size_t cap)
{
    char pat[600];
    const char *fr = strstr(map->pattern[r], "{frame}");
    snprintf(pat, sizeof pat, "%.*s%s%s", (int)(fr - map->pattern[r]), map->pattern[r], key,
             fr + 7);
    DIR *d = opendir(dir);
    if (!d)
        return tnd_fail(TND_ERR_IO, "%s: cannot open directory", dir);
    int found = 0;
    for (struct dirent *e; (e = readdir(d));) {
        /* (the key is literal here: '*' is the only wildcard left) */
        if (e->d_name[0] != '.' && pattern_match(pat, e->d_name, NULL, 0) && found++ == 0)
            snprintf(out, cap, "%s/%s", dir, e->d_name);
    }
    closedir(d);
    if (found != 1)
        return tnd_fail(TND_ERR_BAD_INPUT,
                        "capture: %s: %s file '%s' of this frame (mapping %s, pattern '%s')",
                        primary, found ? "more than one" : "no", map->role[r], map->name, pat);
    return TND_OK;
}

/* ---- loading -------------------------------------------------------------------------------- */
/* One component's channel: a name, or a list of alternatives (the first present wins), into
 * names[0..*alts); false for anything else (null: a constant, for the caller to allow). */
static bool parse_alts(const cJSON *c, char names[MAP_ALTS][128], int *alts)
{
    *alts = 0;
    if (cJSON_IsString(c)) {
        snprintf(names[0], 128, "%s", c->valuestring);
        *alts = 1;
        return true;
    }
    if (!cJSON_IsArray(c))
        return false;
    const cJSON *a;
    cJSON_ArrayForEach(a, c)
    {
        if (cJSON_IsString(a) && *alts < MAP_ALTS)
            snprintf(names[(*alts)++], 128, "%s", a->valuestring);
    }
    return true;
}

/* The first of a component's alternatives present in the file (its full name into full), or
 * NULL. */
static const tnd_exr_channel *find_alt(const tnd_exr_file *x, const char *prefix,
                                       const char names[MAP_ALTS][128], int alts, char *full,
                                       size_t cap)
{
    const tnd_exr_channel *c = NULL;
    for (int a = 0; a < alts && !c; a++) {
        snprintf(full, cap, "%s%s", prefix, names[a]);
        c = tnd_exr_find(x, full);
    }
    return c;
}

static const char *str_item(const cJSON *o, const char *key)
{
    const cJSON *s = cJSON_GetObjectItemCaseSensitive(o, key);
    return cJSON_IsString(s) ? s->valuestring : NULL;
}

static bool load_files(tnd_capture_map *m, const cJSON *root, char *msg, size_t cap)
{
    const cJSON *files = cJSON_GetObjectItemCaseSensitive(root, "files");
    if (!files) {
        m->nfiles = 1;
        snprintf(m->pattern[0], sizeof m->pattern[0], "frame_{frame}.exr");
        return true;
    }
    const cJSON *it;
    if (!cJSON_IsObject(files) || cJSON_GetArraySize(files) == 0) {
        snprintf(msg, cap, "\"files\" must map role names to file patterns");
        return false;
    }
    cJSON_ArrayForEach(it, files)
    {
        const char *fr = cJSON_IsString(it) ? strstr(it->valuestring, "{frame}") : NULL;
        if (!fr || strstr(fr + 1, "{frame}") || m->nfiles == MAP_FILES ||
            strlen(it->string) >= sizeof m->role[0] ||
            strlen(it->valuestring) >= sizeof m->pattern[0]) {
            snprintf(msg, cap,
                     "\"files\": '%s': a pattern with '{frame}' once (at most %d roles) expected",
                     it->string, MAP_FILES);
            return false;
        }
        snprintf(m->role[m->nfiles], sizeof m->role[0], "%s", it->string);
        snprintf(m->pattern[m->nfiles++], sizeof m->pattern[0], "%s", it->valuestring);
    }
    return true;
}

static bool load_camera(tnd_capture_map *m, const cJSON *root, char *msg, size_t cap)
{
    const cJSON *cam = cJSON_GetObjectItemCaseSensitive(root, "camera");
    snprintf(m->cam_attr[0], sizeof m->cam_attr[0], "worldToCamera");
    snprintf(m->cam_attr[1], sizeof m->cam_attr[1], "worldToNDC");
    if (!cam)
        return true;
    const cJSON *xf = cJSON_GetObjectItemCaseSensitive(cam, "xfov_degrees");
    const cJSON *yf = cJSON_GetObjectItemCaseSensitive(cam, "yfov_degrees");
    const cJSON *fovs[2] = {xf, yf};
    float *fov_dst[2] = {&m->xfov, &m->yfov};
    for (int a = 0; a < 2; a++) {
        if (!fovs[a])
            continue;
        if (!cJSON_IsNumber(fovs[a]) || !(fovs[a]->valuedouble > 0) ||
            !(fovs[a]->valuedouble < 180)) {
            snprintf(msg, cap, "camera.%s: degrees in (0, 180) expected",
                     a ? "yfov_degrees" : "xfov_degrees");
            return false;
        }
        *fov_dst[a] = (float)(fovs[a]->valuedouble * TND_PI / 180.0);
    }
    const char *hdr = str_item(cam, "header"), *file = str_item(cam, "file");
    const char *conv = str_item(cam, "convention");
    if (hdr) {
        if (strcmp(hdr, "pbrt") != 0) {
            snprintf(msg, cap, "camera.header: only \"pbrt\" (worldToCamera, worldToNDC)");
            return false;
        }
        m->camera = CAM_PBRT;
        const char *a = str_item(cam, "world_to_camera"), *b = str_item(cam, "world_to_ndc");
        if (a)
            snprintf(m->cam_attr[0], sizeof m->cam_attr[0], "%s", a);
        if (b)
            snprintf(m->cam_attr[1], sizeof m->cam_attr[1], "%s", b);
    } else if (file) {
        if (!conv || strcmp(conv, "mitsuba") != 0) {
            snprintf(msg, cap,
                     "camera.file needs \"convention\": \"mitsuba\" (to_world, fov, "
                     "fov_axis per frame)");
            return false;
        }
        m->camera = CAM_MITSUBA_FILE;
        snprintf(m->cam_file, sizeof m->cam_file, "%s", file);
    }
    return true;
}

/* The options of one entry beyond its channels. */
static bool load_entry_options(tnd_capture_map *m, const tnd_ct_info *ci, const cJSON *it,
                               char *msg, size_t cap)
{
    map_entry *me = &m->e[ci->id];
    const char *keys[2] = {"file", "miss_file"};
    int *roles[2] = {&me->file, &me->miss_file};
    for (int j = 0; j < 2; j++) {
        const char *file = str_item(it, keys[j]);
        if (!file)
            continue;
        *roles[j] = -1;
        for (int r = 0; r < m->nfiles; r++)
            if (strcmp(m->role[r], file) == 0)
                *roles[j] = r;
        if (*roles[j] < 0) {
            snprintf(msg, cap, "entry '%s': \"%s\": '%s' is not a role of \"files\"", ci->name,
                     keys[j], file);
            return false;
        }
    }
    if (!str_item(it, "miss_file"))
        me->miss_file = me->file;
    bool vec3 = ci->id == TND_CT_NORMAL || ci->id == TND_CT_GEO_NORMAL || ci->id == TND_CT_POSITION;
    const char *space = str_item(it, "space");
    if (space) {
        if (!vec3 || (strcmp(space, "camera") != 0 && strcmp(space, "world") != 0)) {
            snprintf(msg, cap,
                     "entry '%s': \"space\": \"camera\" or \"world\", on normal, "
                     "geo_normal and position only",
                     ci->name);
            return false;
        }
        me->camera_space = strcmp(space, "camera") == 0;
        if (me->camera_space && m->camera == CAM_NONE) {
            snprintf(msg, cap,
                     "entry '%s': camera space needs a camera (camera.header or "
                     "camera.file)",
                     ci->name);
            return false;
        }
    }
    if (cJSON_IsTrue(cJSON_GetObjectItemCaseSensitive(it, "face_camera"))) {
        if ((ci->id != TND_CT_NORMAL && ci->id != TND_CT_GEO_NORMAL) || m->camera == CAM_NONE) {
            snprintf(msg, cap, "entry '%s': \"face_camera\": normals only, with a camera",
                     ci->name);
            return false;
        }
        me->face_camera = true;
    }
    const cJSON *zero = cJSON_GetObjectItemCaseSensitive(it, "miss_where_zero");
    if (zero) {
        bool good = ci->id == TND_CT_DEPTH && cJSON_IsArray(zero) &&
                    cJSON_GetArraySize(zero) >= 1 && cJSON_GetArraySize(zero) <= 4;
        me->nzero = good ? (uint32_t)cJSON_GetArraySize(zero) : 0;
        for (uint32_t k = 0; good && k < me->nzero; k++)
            good =
                parse_alts(cJSON_GetArrayItem(zero, (int)k), me->zero_chan[k], &me->zero_alts[k]) &&
                me->zero_alts[k] > 0;
        if (!good) {
            snprintf(msg, cap, "\"miss_where_zero\": 1 to 4 channel names, on depth only");
            return false;
        }
    }
    const cJSON *mv = cJSON_GetObjectItemCaseSensitive(it, "convention");
    if (mv) {
        const char *dif = str_item(mv, "difference"), *unit = str_item(mv, "unit");
        const char *y = str_item(mv, "y");
        bool good = ci->id == TND_CT_MOTION && cJSON_IsObject(mv);
        if (good && dif)
            good = !strcmp(dif, "previous_minus_current") || !strcmp(dif, "current_minus_previous");
        if (good && unit)
            good = !strcmp(unit, "pixels") || !strcmp(unit, "uv") || !strcmp(unit, "ndc");
        if (good && y)
            good = !strcmp(y, "down") || !strcmp(y, "up");
        if (!good) {
            snprintf(msg, cap,
                     "motion \"convention\": {\"difference\": \"previous_minus_current\" "
                     "| \"current_minus_previous\", \"unit\": \"pixels\" | \"uv\" | "
                     "\"ndc\", \"y\": \"down\" | \"up\"}");
            return false;
        }
        me->mv_negate = dif && !strcmp(dif, "current_minus_previous");
        me->mv_unit = !unit || !strcmp(unit, "pixels") ? MV_PIXELS
                      : !strcmp(unit, "uv")            ? MV_UV
                                                       : MV_NDC;
        me->mv_y_up = y && !strcmp(y, "up");
    }
    return true;
}

tnd_result tnd_capture_map_load(const char *path, tnd_capture_map **out)
{
    tnd_result res = TND_OK;
    void *text = NULL;
    size_t size;
    cJSON *root = NULL;
    char msg[512];
    *out = NULL;
    tnd_capture_map *m = calloc(1, sizeof *m);
    if (!m)
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "mapping: out of memory");
    snprintf(m->path, sizeof m->path, "%s", path);
    TND_TRY(tnd_file_read(path, &text, &size));
    root = cJSON_ParseWithLength(text, size);
    if (!root) {
        res = map_error(path, "not valid JSON");
        goto fail;
    }
    const cJSON *ver = cJSON_GetObjectItemCaseSensitive(root, "tandem_mapping");
    if (!cJSON_IsNumber(ver) || ver->valuedouble != 1.0) {
        res = map_error(path, "\"tandem_mapping\": 1 expected (the mapping format version)");
        goto fail;
    }
    const cJSON *s = cJSON_GetObjectItemCaseSensitive(root, "name");
    snprintf(m->name, sizeof m->name, "%s", cJSON_IsString(s) ? s->valuestring : path);
    s = cJSON_GetObjectItemCaseSensitive(root, "prefix");
    if (s && !cJSON_IsString(s)) {
        res = map_error(path, "\"prefix\" must be a string");
        goto fail;
    }
    snprintf(m->prefix, sizeof m->prefix, "%s", s ? s->valuestring : "");
    if (!load_files(m, root, msg, sizeof msg) || !load_camera(m, root, msg, sizeof msg)) {
        res = map_error(path, msg);
        goto fail;
    }
    const cJSON *world = cJSON_GetObjectItemCaseSensitive(root, "world");
    if (world) {
        const char *up = str_item(world, "up");
        if (!up || (strcmp(up, "+y") != 0 && strcmp(up, "+z") != 0)) {
            res = map_error(path, "world.up: \"+y\" (Tandem's, glTF's) or \"+z\"");
            goto fail;
        }
        m->z_up = strcmp(up, "+z") == 0;
    }
    const cJSON *entries = cJSON_GetObjectItemCaseSensitive(root, "entries");
    if (!cJSON_IsObject(entries)) {
        res = map_error(path, "\"entries\" object expected");
        goto fail;
    }
    for (int i = 0; i < TND_CT_COUNT; i++)
        m->e[i].divide_by = m->e[i].subtract = -1;
    const cJSON *it;
    cJSON_ArrayForEach(it, entries)
    {
        const tnd_ct_info *ci = tnd_ct_find(it->string);
        if (!ci) {
            snprintf(msg, sizeof msg, "entry '%s' is not a contract entry", it->string);
            res = map_error(path, msg);
            goto fail;
        }
        map_entry *me = &m->e[ci->id];
        const char *conv = str_item(it, "convert");
        const char *rec = str_item(it, "reconstruct");
        if (rec) {
            if (ci->id != TND_CT_MOTION || strcmp(rec, "position") != 0 || m->camera == CAM_NONE) {
                res = map_error(path, "\"reconstruct\": \"position\", on motion only, with a "
                                      "camera (camera.header or camera.file)");
                goto fail;
            }
            me->reconstruct = me->fed = true;
            continue;
        }
        if (cJSON_GetObjectItemCaseSensitive(it, "convert") && !conv) {
            res = map_error(path, "\"convert\" must be a string");
            goto fail;
        }
        if (conv) {
            bool p2d = strcmp(conv, "planar_to_distance") == 0, len = strcmp(conv, "length") == 0;
            if ((!p2d && !len) || ci->id != TND_CT_DEPTH) {
                res = map_error(path, "\"convert\": \"planar_to_distance\" or \"length\", on "
                                      "depth only");
                goto fail;
            }
            if (p2d && m->xfov <= 0 && m->yfov <= 0) {
                res = map_error(path, "\"planar_to_distance\" needs camera.xfov_degrees or "
                                      "camera.yfov_degrees");
                goto fail;
            }
            me->planar_to_distance = p2d;
            me->length = len;
        }
        const cJSON *opt = cJSON_GetObjectItemCaseSensitive(it, "optional");
        if (opt) {
            if (!cJSON_IsString(opt) || !opt->valuestring[0] ||
                strlen(opt->valuestring) >= sizeof me->fallback ||
                tnd_ct_get(ci->id)->need == TND_NEED_REQUIRED) {
                snprintf(msg, sizeof msg,
                         "entry '%s': \"optional\" must state in words what happens without it "
                         "(and the entry must not be required by the contract)",
                         ci->name);
                res = map_error(path, msg);
                goto fail;
            }
            snprintf(me->fallback, sizeof me->fallback, "%s", opt->valuestring);
        }
        me->nchan = me->length ? 3 : ci->comps;
        const cJSON *chans = cJSON_GetObjectItemCaseSensitive(it, "channels");
        if (!cJSON_IsArray(chans) || cJSON_GetArraySize(chans) != (int)me->nchan) {
            snprintf(msg, sizeof msg, "entry '%s': \"channels\" must list %u channel(s)%s",
                     ci->name, me->nchan,
                     me->length ? " (a vector whose length is the depth)" : "");
            res = map_error(path, msg);
            goto fail;
        }
        for (uint32_t k = 0; k < me->nchan; k++) {
            const cJSON *c = cJSON_GetArrayItem(chans, (int)k);
            me->scale[k] = 1.0f;
            if (!parse_alts(c, me->chan[k], &me->alts[k]) && !cJSON_IsNull(c)) {
                snprintf(msg, sizeof msg,
                         "entry '%s': channel %u must be a name, a list of names or null", ci->name,
                         k);
                res = map_error(path, msg);
                goto fail;
            }
        }
        const char *vec_keys[2] = {"scale", "offset"};
        float *vec_dst[2] = {me->scale, me->offset};
        for (int v = 0; v < 2; v++) {
            const cJSON *a = cJSON_GetObjectItemCaseSensitive(it, vec_keys[v]);
            if (!a)
                continue;
            bool good = cJSON_IsNumber(a) || (cJSON_IsArray(a) &&
                                               cJSON_GetArraySize(a) == (int)me->nchan);
            for (uint32_t k = 0; good && k < me->nchan; k++)
                good = float_item(cJSON_IsArray(a) ? cJSON_GetArrayItem(a, (int)k) : a,
                                  &vec_dst[v][k]);
            if (!good) {
                snprintf(msg, sizeof msg,
                         "entry '%s': \"%s\" must be a finite number or %u finite numbers",
                         ci->name, vec_keys[v], me->nchan);
                res = map_error(path, msg);
                goto fail;
            }
        }
        me->normalize = cJSON_IsTrue(cJSON_GetObjectItemCaseSensitive(it, "normalize"));
        const cJSON *miss = cJSON_GetObjectItemCaseSensitive(it, "miss_at_or_above");
        if (miss) {
            if (!float_item(miss, &me->miss_at) || ci->id != TND_CT_DEPTH ||
                !(me->miss_at > 0)) {
                res = map_error(path,
                                "\"miss_at_or_above\": a positive finite number, on depth only");
                goto fail;
            }
        }
        const cJSON *div = cJSON_GetObjectItemCaseSensitive(it, "divide_by");
        if (div) {
            const tnd_ct_info *d = cJSON_IsString(div) ? tnd_ct_find(div->valuestring) : NULL;
            if (!d || d->comps != ci->comps || d->id == ci->id) {
                snprintf(msg, sizeof msg,
                         "entry '%s': \"divide_by\" must name another entry with %u components",
                         ci->name, ci->comps);
                res = map_error(path, msg);
                goto fail;
            }
            me->divide_by = (int)d->id;
        }
        const cJSON *mc = cJSON_GetObjectItemCaseSensitive(it, "miss_channels");
        if (mc) {
            bool good = cJSON_IsArray(mc) && cJSON_GetArraySize(mc) == (int)ci->comps &&
                        ci->kind == TND_CT_FLOAT && ci->id != TND_CT_DEPTH;
            for (uint32_t k = 0; good && k < ci->comps; k++)
                good = parse_alts(cJSON_GetArrayItem(mc, (int)k), me->miss_chan[k],
                                  &me->miss_alts[k]) &&
                       me->miss_alts[k] > 0;
            if (!good) {
                snprintf(msg, sizeof msg,
                         "entry '%s': \"miss_channels\" must list %u channel name(s) (float "
                         "entries but depth)",
                         ci->name, ci->comps);
                res = map_error(path, msg);
                goto fail;
            }
            me->on_miss = true;
        }
        const cJSON *sub = cJSON_GetObjectItemCaseSensitive(it, "subtract");
        if (sub) {
            const tnd_ct_info *d = cJSON_IsString(sub) ? tnd_ct_find(sub->valuestring) : NULL;
            if (!d || d->comps != ci->comps || d->id == ci->id ||
                (me->divide_by >= 0 && d->id == (tnd_ct)me->divide_by)) {
                snprintf(msg, sizeof msg,
                         "entry '%s': \"subtract\" must name another entry with %u components "
                         "(not its divide_by)",
                         ci->name, ci->comps);
                res = map_error(path, msg);
                goto fail;
            }
            me->subtract = (int)d->id;
        }
        if (!load_entry_options(m, ci, it, msg, sizeof msg)) {
            res = map_error(path, msg);
            goto fail;
        }
        me->fed = true;
    }
    *out = m;
    m = NULL;
fail:
    cJSON_Delete(root);
    free(text);
    free(m);
    return res;
}

const char *tnd_capture_map_fallback(const tnd_capture_map *map, tnd_ct e)
{
    return (unsigned)e < TND_CT_COUNT && map->e[e].fed && map->e[e].fallback[0] ? map->e[e].fallback
                                                                               : NULL;
}

const char *tnd_capture_map_name(const tnd_capture_map *map)
{
    return map->name;
}

bool tnd_capture_map_source(const tnd_capture_map *map, tnd_ct e, char *buf, size_t cap)
{
    const map_entry *me = &map->e[e];
    if (!me->fed)
        return false;
    size_t n = 0;
#define PUT(...)                                                                                   \
    do {                                                                                           \
        int w_ = snprintf(buf + n, n < cap ? cap - n : 0, __VA_ARGS__);                            \
        n += w_ > 0 && (size_t)w_ < cap - n ? (size_t)w_ : 0;                                      \
    } while (0)
    buf[0] = '\0';
    if (me->reconstruct) {
        PUT("reconstructed from the position and the cameras of this frame and the last");
        return true;
    }
    if (map->nfiles > 1)
        PUT("%s: ", map->role[me->file]);
    for (uint32_t k = 0; k < me->nchan; k++) {
        if (me->alts[k] == 0)
            PUT("%s%g", k ? ", " : "", (double)me->offset[k]);
        else
            PUT("%s%s%s%s", k ? ", " : "", map->prefix, me->chan[k][0],
                me->alts[k] > 1 ? " (or alternatives)" : "");
        if (me->alts[k] && (me->scale[k] != 1.0f || me->offset[k] != 0.0f))
            PUT(" x %g + %g", (double)me->scale[k], (double)me->offset[k]);
    }
    if (me->planar_to_distance)
        PUT("; planar depth to distance");
    if (me->length)
        PUT("; its length");
    if (me->nzero)
        PUT("; a miss where %s%s... is 0", map->prefix, me->zero_chan[0][0]);
    if (me->camera_space)
        PUT("; camera to world space");
    if (me->face_camera)
        PUT("; facing the camera");
    if (e == TND_CT_MOTION && (me->mv_negate || me->mv_unit != MV_PIXELS || me->mv_y_up))
        PUT("; %s in %s, y %s", me->mv_negate ? "current - previous" : "previous - current",
            me->mv_unit == MV_UV    ? "uv"
            : me->mv_unit == MV_NDC ? "ndc"
                                    : "pixels",
            me->mv_y_up ? "up" : "down");
    if (me->normalize)
        PUT("; normalised");
    if (me->subtract >= 0)
        PUT("; minus %s", tnd_ct_get((tnd_ct)me->subtract)->name);
    if (me->divide_by >= 0)
        PUT("; divided by %s", tnd_ct_get((tnd_ct)me->divide_by)->name);
    if (me->on_miss)
        PUT("; on a miss: %s%s...", map->prefix, me->miss_chan[0][0]);
#undef PUT
    return true;
}

void tnd_capture_map_destroy(tnd_capture_map *map)
{
    free(map);
}

/* ---- cameras -------------------------------------------------------------------------------- */
/* Where a renderer's camera coordinates come from Tandem's view space (x right, y up, looking
 * down -z): pbrt's camera looks down +z (x right, y up), Mitsuba's too with +x to the left. */
static void camera_axes(int kind, float k[3])
{
    k[0] = kind == CAM_MITSUBA_FILE ? -1.0f : 1.0f;
    k[1] = 1.0f;
    k[2] = kind == CAM_NONE ? 1.0f : -1.0f;
}

static void row_major(const float *a, float out[16])
{
    for (int r = 0; r < 4; r++)
        for (int c = 0; c < 4; c++)
            out[c * 4 + r] = a[4 * r + c];
}

/* pbrt-v4's header: worldToCamera C and worldToNDC N = T(0.5) S(0.5) screenFromCamera C, NDC in
 * [0,1] over the default screen window ([-a,a] x [-1,1] for a = W/H >= 1, else [-1,1] x
 * [-1/a, 1/a]), y up. Tandem's view = diag(1,1,-1) C; its proj takes NDC to Vulkan clip space
 * (x = screen.x / ax, y = -screen.y / ay): proj = B N C^-1 diag(1,1,-1). */
static bool camera_pbrt(const tnd_capture_map *map, const tnd_exr_file *x, tnd_camera_state *cam)
{
    float a[16], b[16], C[16], N[16], Ci[16], t[16];
    if (!tnd_exr_attr_m44f(x, map->cam_attr[0], a) || !tnd_exr_attr_m44f(x, map->cam_attr[1], b))
        return false;
    row_major(a, C);
    row_major(b, N);
    memcpy(cam->view, C, sizeof C);
    for (int c = 0; c < 4; c++)
        cam->view[c * 4 + 2] = -C[c * 4 + 2];
    if (!tnd_mat4_inverse(C, Ci))
        return false;
    float F[16];
    tnd_mat4_identity(F);
    F[10] = -1.0f;
    double aspect = (double)x->width / x->height;
    float ax = (float)(aspect >= 1 ? aspect : 1.0), ay = (float)(aspect >= 1 ? 1.0 : 1.0 / aspect);
    float B[16] = {0};
    B[0] = 2.0f / ax, B[12] = -1.0f / ax;
    B[5] = -2.0f / ay, B[13] = 1.0f / ay;
    B[10] = 1.0f, B[15] = 1.0f;
    tnd_mat4_mul(Ci, F, t);
    float u[16];
    tnd_mat4_mul(N, t, u);
    tnd_mat4_mul(B, u, cam->proj);
    return true;
}

/* Mitsuba's perspective sensor, one frame of a cameras file: to_world (row-major, camera to
 * world; camera +x left, +y up, looking down +z), fov in degrees along fov_axis. */
static tnd_result camera_mitsuba(const tnd_capture_map *map, const char *dir, const char *key,
                                 const char *primary, uint32_t W, uint32_t H, tnd_camera_state *cam)
{
    tnd_result res = TND_OK;
    char path[1400];
    void *text = NULL;
    size_t size;
    cJSON *root = NULL;
    snprintf(path, sizeof path, "%s/%s", dir, map->cam_file);
    TND_TRY(tnd_file_read(path, &text, &size));
    root = cJSON_ParseWithLength(text, size);
    const cJSON *frames = root ? cJSON_GetObjectItemCaseSensitive(root, "frames") : NULL;
    const cJSON *fr = cJSON_IsObject(frames) ? cJSON_GetObjectItemCaseSensitive(frames, key) : NULL;
    const cJSON *tw = fr ? cJSON_GetObjectItemCaseSensitive(fr, "to_world") : NULL;
    const cJSON *fov = fr ? cJSON_GetObjectItemCaseSensitive(fr, "fov") : NULL;
    const char *axis = fr ? str_item(fr, "fov_axis") : NULL;
    float a[16], tow[16], C[16];
    bool good = cJSON_IsArray(tw) && cJSON_GetArraySize(tw) == 16 && cJSON_IsNumber(fov) &&
                fov->valuedouble > 0 && fov->valuedouble < 180;
    for (int i = 0; good && i < 16; i++) {
        const cJSON *v = cJSON_GetArrayItem(tw, i);
        a[i] = 0.0f;
        good = float_item(v, &a[i]);
    }
    if (good && axis)
        good = !strcmp(axis, "x") || !strcmp(axis, "y") || !strcmp(axis, "smaller") ||
               !strcmp(axis, "larger");
    if (!good) {
        res = tnd_fail(TND_ERR_BAD_INPUT,
                       "capture: %s: %s has no camera for frame '%s' (\"frames\": {\"%s\": "
                       "{\"to_world\": 16 numbers, row-major, \"fov\": degrees, \"fov_axis\": "
                       "\"x\"}})",
                       primary, path, key, key);
        goto fail;
    }
    row_major(a, tow);
    if (!tnd_mat4_inverse(tow, C)) {
        res =
            tnd_fail(TND_ERR_BAD_INPUT, "capture: %s: frame '%s': to_world is singular", path, key);
        goto fail;
    }
    float k[3];
    camera_axes(CAM_MITSUBA_FILE, k);
    for (int c = 0; c < 4; c++)
        for (int r = 0; r < 3; r++)
            cam->view[c * 4 + r] = k[r] * C[c * 4 + r];
    for (int c = 0; c < 4; c++)
        cam->view[c * 4 + 3] = C[c * 4 + 3];
    double aspect = (double)W / H, f = fov->valuedouble * TND_PI / 180.0;
    bool along_x = !axis || !strcmp(axis, "x") || (!strcmp(axis, "smaller") && aspect <= 1) ||
                   (!strcmp(axis, "larger") && aspect > 1);
    double yfov = along_x ? 2.0 * atan(tan(0.5 * f) / aspect) : f;
    tnd_mat4_perspective((float)yfov, (float)aspect, 0.01f, 0.0f, cam->proj);
fail:
    cJSON_Delete(root);
    free(text);
    return res;
}

/* ---- reading -------------------------------------------------------------------------------- */
typedef struct map_files {
    tnd_exr_file x[MAP_FILES];
    bool open[MAP_FILES];
} map_files;

/* Role r's file of this frame, opened on first use; NULL after adding a problem. */
static const tnd_exr_file *frame_file(const tnd_capture_map *map, map_files *mf, int r,
                                      const char *dir, const char *key, const char *primary,
                                      cap_problems *p)
{
    if (mf->open[r])
        return &mf->x[r];
    char path[1400];
    tnd_result res = role_file(map, r, dir, key, primary, path, sizeof path);
    if (res == TND_OK)
        res = tnd_exr_read(path, &mf->x[r]);
    if (res != TND_OK) {
        cap_problem_add(p, "%s", tnd_error_detail());
        return NULL;
    }
    mf->open[r] = true;
    if (mf->x[r].width != mf->x[0].width || mf->x[r].height != mf->x[0].height) {
        cap_problem_add(p, "%s: %ux%u, the frame's %s file is %ux%u", path, mf->x[r].width,
                        mf->x[r].height, map->role[0][0] ? map->role[0] : "first", mf->x[0].width,
                        mf->x[0].height);
        return NULL;
    }
    return &mf->x[r];
}

/* Pixel position of world point (w = 1) or direction (w = 0) p under a camera, in double. */
static bool to_pixel(const float view[16], const float proj[16], const double p[3], double w,
                     uint32_t W, uint32_t H, double out[2])
{
    double v[4], c[4];
    for (int r = 0; r < 4; r++)
        v[r] = view[r] * p[0] + view[4 + r] * p[1] + view[8 + r] * p[2] + view[12 + r] * w;
    for (int r = 0; r < 4; r++)
        c[r] = proj[r] * v[0] + proj[4 + r] * v[1] + proj[8 + r] * v[2] + proj[12 + r] * v[3];
    if (!(fabs(c[3]) > 1e-30))
        return false;
    out[0] = (c[0] / c[3] * 0.5 + 0.5) * W;
    out[1] = (c[1] / c[3] * 0.5 + 0.5) * H;
    return isfinite(out[0]) && isfinite(out[1]);
}

static void camera_position(const float view[16], double pos[3])
{
    float inv[16];
    tnd_mat4_inverse(view, inv);
    for (int k = 0; k < 3; k++)
        pos[k] = inv[12 + k];
}

/* After the entries: camera-space vectors to world, the world turned to +Y up, normals facing
 * the camera, and motion reconstructed from the position. */
static void finish_frame(const tnd_capture_map *map, int cam_kind, const tnd_camera_state *prev,
                         tnd_frame *f)
{
    size_t npx = (size_t)f->width * f->height;
    float inv_view[16], k[3];
    camera_axes(cam_kind, k);
    if (f->has_camera)
        tnd_mat4_inverse(f->camera.view, inv_view);
    const tnd_ct vecs[3] = {TND_CT_NORMAL, TND_CT_GEO_NORMAL, TND_CT_POSITION};
    for (int i = 0; i < 3; i++) {
        const map_entry *me = &map->e[vecs[i]];
        float *v = tnd_frame_f(f, vecs[i]);
        if (!f->present[vecs[i]])
            continue;
        bool point = vecs[i] == TND_CT_POSITION;
        for (size_t q = 0; me->camera_space && q < npx; q++) {
            float c[3] = {k[0] * v[3 * q], k[1] * v[3 * q + 1], k[2] * v[3 * q + 2]}, o[3];
            if (point)
                tnd_mat4_point(inv_view, c, false, o);
            else
                tnd_mat4_dir(inv_view, c, o);
            memcpy(v + 3 * q, o, sizeof o);
        }
        for (size_t q = 0; map->z_up && q < npx; q++) { /* (x, y, z) -> (x, z, -y) */
            float y = v[3 * q + 1];
            v[3 * q + 1] = v[3 * q + 2];
            v[3 * q + 2] = -y;
        }
        for (size_t q = 0; !point && me->camera_space && q < npx; q++) {
            float *n = v + 3 * q;
            double l = sqrt((double)n[0] * n[0] + (double)n[1] * n[1] + (double)n[2] * n[2]);
            for (int c = 0; c < 3; c++)
                n[c] = l > 0 ? (float)(n[c] / l) : 0.0f;
        }
    }
    if (map->z_up && f->has_camera) { /* view' = view R^T: column 1 is column 2, column 2 is
                                       * minus column 1 */
        for (int r = 0; r < 4; r++) {
            float c1 = f->camera.view[4 + r], c2 = f->camera.view[8 + r];
            f->camera.view[4 + r] = c2;
            f->camera.view[8 + r] = -c1;
        }
    }
    if (f->has_camera && cam_kind != CAM_NONE) { /* (Tandem's attributes carry their own) */
        memcpy(f->camera.prev_view, prev ? prev->view : f->camera.view, sizeof f->camera.view);
        memcpy(f->camera.prev_proj, prev ? prev->proj : f->camera.proj, sizeof f->camera.proj);
    }
}

/* Needs the position (fed or derived) and the camera. */
static void finish_after_derive(const tnd_capture_map *map, tnd_frame *f)
{
    if (!f->has_camera || !f->present[TND_CT_POSITION])
        return;
    size_t npx = (size_t)f->width * f->height;
    double cp[3], pp[3];
    camera_position(f->camera.view, cp);
    camera_position(f->camera.prev_view, pp);
    const float *pos = tnd_frame_f(f, TND_CT_POSITION), *depth = tnd_frame_f(f, TND_CT_DEPTH);
    for (int i = 0; i < 2; i++) {
        tnd_ct id = i ? TND_CT_GEO_NORMAL : TND_CT_NORMAL;
        if (!map->e[id].face_camera)
            continue;
        float *n = tnd_frame_f(f, id);
        for (size_t q = 0; q < npx; q++) {
            double d = 0;
            for (int c = 0; c < 3; c++)
                d += ((double)pos[3 * q + c] - cp[c]) * n[3 * q + c];
            if (d > 0 && depth[q] < (float)TND_DEPTH_MISS)
                for (int c = 0; c < 3; c++)
                    n[3 * q + c] = -n[3 * q + c];
        }
    }
    if (!map->e[TND_CT_MOTION].reconstruct)
        return;
    float *mo = tnd_frame_f(f, TND_CT_MOTION);
    for (uint32_t y = 0; y < f->height; y++)
        for (uint32_t x = 0; x < f->width; x++) {
            size_t q = (size_t)y * f->width + x;
            double p[3], now[2] = {x + 0.5, y + 0.5}, before[2], w = 0.0, dz = 0.0;
            if (depth[q] < (float)TND_DEPTH_MISS) {
                double dc = 0, dp = 0;
                for (int c = 0; c < 3; c++) {
                    p[c] = pos[3 * q + c];
                    dc += (p[c] - cp[c]) * (p[c] - cp[c]);
                    dp += (p[c] - pp[c]) * (p[c] - pp[c]);
                }
                w = 1.0;
                dz = sqrt(dp) - sqrt(dc);
                if (!to_pixel(f->camera.view, f->camera.proj, p, 1.0, f->width, f->height, now))
                    now[0] = x + 0.5, now[1] = y + 0.5;
            } else { /* a point at infinity along the pixel's ray */
                float o[3], d[3];
                tnd_camera_ray(&f->camera, f->width, f->height, (float)x + 0.5f, (float)y + 0.5f, o,
                               d);
                for (int c = 0; c < 3; c++)
                    p[c] = d[c];
            }
            if (!to_pixel(f->camera.prev_view, f->camera.prev_proj, p, w, f->width, f->height,
                          before))
                before[0] = now[0], before[1] = now[1];
            mo[3 * q] = (float)(before[0] - now[0]);
            mo[3 * q + 1] = (float)(before[1] - now[1]);
            mo[3 * q + 2] = (float)dz;
        }
    f->present[TND_CT_MOTION] = true;
}

/* One entry from its channels, with its conversions, into f. */
/* Whether every channel the entry reads is in the file. */
static bool entry_in_file(const tnd_capture_map *map, const map_entry *me, const tnd_exr_file *x)
{
    char full[300];
    for (uint32_t k = 0; k < me->nchan; k++)
        if (me->alts[k] && !find_alt(x, map->prefix, me->chan[k], me->alts[k], full, sizeof full))
            return false;
    return true;
}

static void read_entry(const tnd_capture_map *map, int i, const map_entry *me,
                       const tnd_exr_file *x, const tnd_exr_file *xm, const char *path,
                       tnd_frame *f, cap_problems *p)
{
    const tnd_ct_info *e = tnd_ct_get((tnd_ct)i);
    size_t npx = (size_t)x->width * x->height;
    const float *src[4] = {0};
    bool ok = true;
    for (uint32_t k = 0; k < me->nchan; k++) {
        if (me->alts[k] == 0)
            continue; /* constant: offset */
        char full[300] = "";
        const tnd_exr_channel *c =
            find_alt(x, map->prefix, me->chan[k], me->alts[k], full, sizeof full);
        if (!c) {
            cap_problem_add(p, "entry '%s': channel '%s%s' not in %s", e->name, map->prefix,
                            me->chan[k][0], map->nfiles > 1 ? map->role[me->file] : "the file");
            ok = false;
        } else if (!c->data || c->type == TND_EXR_UINT) {
            cap_problem_add(p, "channel '%s': %s", full,
                            c->data ? "wrong type UINT (expected HALF or FLOAT)"
                                    : "wrong size (subsampled)");
            ok = false;
        } else {
            src[k] = c->data; /* (non-finite values: counted and replaced below) */
        }
    }
    if (!ok || e->kind != TND_CT_FLOAT)
        return;
    float *dst = f->data[i];
    for (size_t q = 0; q < npx; q++) {
        if (me->length) {
            double l = 0;
            for (uint32_t k = 0; k < 3; k++) {
                double v = (double)(src[k] ? src[k][q] : 0.0f) * me->scale[k] + me->offset[k];
                l += v * v;
            }
            dst[q] = (float)sqrt(l);
            continue;
        }
        for (uint32_t k = 0; k < e->comps; k++)
            dst[q * e->comps + k] = (src[k] ? src[k][q] : 0.0f) * me->scale[k] + me->offset[k];
    }
    /* Another renderer's NaN and infinities (a division by zero, a firefly past half's range)
     * never enter the back-end: counted, said once per file and entry, and replaced by a miss
     * (depth) or 0 (anything else: no light, no motion), before any conversion could hide them */
    size_t bad = 0, first = 0;
    for (size_t q = 0; q < npx * e->comps; q++)
        if (!isfinite(dst[q])) {
            if (bad++ == 0)
                first = q / e->comps;
            dst[q] = i == TND_CT_DEPTH ? (float)TND_DEPTH_MISS : 0.0f;
        }
    if (bad)
        tnd_warn("capture",
                 "%s: entry '%s': %zu non-finite value%s (first at pixel %zu,%zu) set to %s", path,
                 e->name, bad, bad == 1 ? "" : "s", first % x->width, first / x->width,
                 i == TND_CT_DEPTH ? "a miss" : "0");
    f->nonfinite[i] = (uint32_t)(bad < UINT32_MAX ? bad : UINT32_MAX);
    if (i == TND_CT_MOTION) { /* to previous - current, pixels, y down */
        float sx = me->mv_unit == MV_UV    ? (float)x->width
                   : me->mv_unit == MV_NDC ? 0.5f * x->width
                                           : 1;
        float sy = me->mv_unit == MV_UV    ? (float)x->height
                   : me->mv_unit == MV_NDC ? 0.5f * x->height
                                           : 1;
        float sg = me->mv_negate ? -1.0f : 1.0f;
        for (size_t q = 0; q < npx; q++) {
            dst[3 * q] *= sg * sx;
            dst[3 * q + 1] *= sg * sy * (me->mv_y_up ? -1.0f : 1.0f);
            dst[3 * q + 2] *= sg;
        }
    }
    if (me->normalize)
        for (size_t q = 0; q < npx; q++) {
            float *v = dst + q * e->comps;
            double l = 0;
            for (uint32_t k = 0; k < e->comps; k++)
                l += (double)v[k] * v[k];
            l = l > 0 ? 1.0 / sqrt(l) : 0.0;
            for (uint32_t k = 0; k < e->comps; k++)
                v[k] = (float)(v[k] * l);
        }
    if (i == TND_CT_DEPTH) { /* a foreign "no hit" marker becomes TND_DEPTH_MISS */
        const float *zero[4] = {0};
        for (uint32_t k = 0; k < me->nzero; k++) {
            char full[300] = "";
            const tnd_exr_channel *c =
                find_alt(x, map->prefix, me->zero_chan[k], me->zero_alts[k], full, sizeof full);
            if (!c || !c->data || c->type == TND_EXR_UINT) {
                cap_problem_add(p,
                                "depth: miss_where_zero channel '%s%s' not in the file as "
                                "float",
                                map->prefix, me->zero_chan[k][0]);
                return;
            }
            zero[k] = c->data;
        }
        for (size_t q = 0; q < npx; q++) {
            bool z = me->nzero > 0;
            for (uint32_t k = 0; k < me->nzero; k++)
                z &= zero[k][q] == 0.0f;
            if (z || !(dst[q] > 0.0f) || (me->miss_at > 0 && dst[q] >= me->miss_at))
                dst[q] = (float)TND_DEPTH_MISS;
        }
    }
    if (me->planar_to_distance) {
        /* distance = planar depth x |(u, v, 1)| for the pinhole ray through the pixel */
        double W = x->width, H = x->height;
        double fx = map->xfov > 0 ? 0.5 * W / tan(0.5 * map->xfov) : 0;
        double fy = map->yfov > 0 ? 0.5 * H / tan(0.5 * map->yfov) : fx;
        if (fx == 0)
            fx = fy;
        for (uint32_t yy = 0; yy < x->height; yy++)
            for (uint32_t xx = 0; xx < x->width; xx++) {
                double u = (xx + 0.5 - 0.5 * W) / fx, v = (yy + 0.5 - 0.5 * H) / fy;
                float *d = dst + (size_t)yy * x->width + xx;
                if (*d < (float)TND_DEPTH_MISS)
                    *d = (float)(*d * sqrt(1.0 + u * u + v * v));
            }
    }
    if (me->subtract >= 0) {
        const float *sb = f->data[me->subtract];
        for (size_t q = 0; q < npx * e->comps; q++)
            dst[q] = fmaxf(dst[q] - sb[q], 0.0f);
    }
    if (me->divide_by >= 0) {
        const float *div = f->data[me->divide_by];
        for (size_t q = 0; q < npx * e->comps; q++)
            dst[q] /= fmaxf(div[q], 0.01f);
    }
    if (me->on_miss && xm) { /* (depth, entry 4, is converted before any later entry) */
        const float *depth = f->data[TND_CT_DEPTH];
        for (uint32_t k = 0; k < e->comps; k++) {
            char full[300] = "";
            const tnd_exr_channel *c =
                find_alt(xm, map->prefix, me->miss_chan[k], me->miss_alts[k], full, sizeof full);
            if (!c || !c->data || c->type == TND_EXR_UINT) {
                cap_problem_add(p, "entry '%s': miss channel '%s%s' not in the file as float",
                                e->name, map->prefix, me->miss_chan[k][0]);
                break;
            }
            for (size_t q = 0; q < npx; q++)
                if (depth[q] >= (float)TND_DEPTH_MISS)
                    dst[q * e->comps + k] = ((const float *)c->data)[q];
        }
    }
    /* (what the conversions could still make non-finite, and the miss channels) */
    for (size_t q = 0; q < npx * e->comps; q++)
        if (!isfinite(dst[q])) {
            dst[q] = i == TND_CT_DEPTH ? (float)TND_DEPTH_MISS : 0.0f;
            f->nonfinite[i] += f->nonfinite[i] < UINT32_MAX;
        }
    f->present[i] = true;
}

tnd_result tnd_capture_read_mapped(const char *path, const tnd_capture_map *map,
                                   const tnd_camera_state *prev, tnd_frame *f)
{
    memset(f, 0, sizeof *f);
    cap_problems p = {{0}, 0};
    for (int i = 0; i < TND_CT_COUNT; i++) {
        const tnd_ct_info *e = tnd_ct_get((tnd_ct)i);
        if (e->need == TND_NEED_REQUIRED && !map->e[i].fed)
            cap_problem_add(&p, "required entry '%s' is not fed by the mapping", e->name);
    }
    if (p.count)
        return tnd_fail(TND_ERR_BAD_INPUT, "mapping: %s: %d problem%s:%s", map->path, p.count,
                        p.count == 1 ? "" : "s", p.text);
    /* the frame's key and directory, for its other files and its camera */
    char dir[1100], key[256] = "";
    const char *slash = strrchr(path, '/'), *base = slash ? slash + 1 : path;
    snprintf(dir, sizeof dir, "%.*s", slash ? (int)(slash - path) : 1, slash ? path : ".");
    bool keyed = pattern_match(map->pattern[0], base, key, sizeof key);
    map_files *mf = calloc(1, sizeof *mf);
    if (!mf)
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "capture: out of memory");
    tnd_result res = tnd_exr_read(path, &mf->x[0]);
    if (res != TND_OK) {
        free(mf);
        return res;
    }
    mf->open[0] = true;
    const tnd_exr_file *x0 = &mf->x[0];
    TND_TRY(tnd_frame_create(x0->width, x0->height, f));
    cap_read_tandem_camera(x0, f);
    int cam_kind = CAM_NONE;
    if (!f->has_camera && map->camera == CAM_PBRT) {
        if (!camera_pbrt(map, x0, &f->camera))
            cap_problem_add(&p,
                            "no camera: the header lacks m44f '%s' and '%s' (or they are "
                            "singular)",
                            map->cam_attr[0], map->cam_attr[1]);
        f->has_camera = p.count == 0, cam_kind = CAM_PBRT;
    } else if (!f->has_camera && map->camera == CAM_MITSUBA_FILE) {
        if (!keyed) {
            res = tnd_fail(TND_ERR_BAD_INPUT,
                           "capture: %s: the name does not match '%s' (mapping "
                           "%s)",
                           path, map->pattern[0], map->name);
            goto fail;
        }
        TND_TRY(camera_mitsuba(map, dir, key, path, x0->width, x0->height, &f->camera));
        f->has_camera = true, cam_kind = CAM_MITSUBA_FILE;
    }
    /* Two passes so that divide_by and subtract see their entries already converted. */
    for (int pass = 0; pass < 2; pass++)
        for (int i = 0; i < TND_CT_COUNT; i++) {
            const map_entry *me = &map->e[i];
            if (!me->fed || me->reconstruct ||
                (me->divide_by >= 0 || me->subtract >= 0) != (pass == 1))
                continue;
            if ((me->file > 0 || me->miss_file > 0) && !keyed) {
                cap_problem_add(&p, "the name does not match '%s': no '%s' file", map->pattern[0],
                                map->role[me->file > 0 ? me->file : me->miss_file]);
                continue;
            }
            const tnd_exr_file *x = frame_file(map, mf, me->file, dir, key, path, &p);
            const tnd_exr_file *xm =
                me->on_miss ? frame_file(map, mf, me->miss_file, dir, key, path, &p) : NULL;
            if (x && me->fallback[0] && !entry_in_file(map, me, x)) {
                /* optional and absent: its default (0) stands where a surface is hit; its
                 * miss channels (the background) still fill the misses */
                f->fallback[i] = true;
                map_entry zero = *me;
                for (uint32_t k = 0; k < zero.nchan; k++)
                    zero.alts[k] = 0, zero.offset[k] = 0;
                if (me->on_miss && xm)
                    read_entry(map, i, &zero, x, xm, path, f, &p);
                continue;
            }
            if (x && (xm || !me->on_miss))
                read_entry(map, i, me, x, xm, path, f, &p);
        }
    if (p.count) {
        res = tnd_fail(TND_ERR_BAD_INPUT, "capture: %s (mapping %s): %d problem%s:%s", path,
                       map->name, p.count, p.count == 1 ? "" : "s", p.text);
        goto fail;
    }
    finish_frame(map, cam_kind, prev, f);
    TND_TRY(tnd_frame_derive(f, path));
    finish_after_derive(map, f);
    for (int r = 0; r < MAP_FILES; r++)
        if (mf->open[r])
            tnd_exr_close(&mf->x[r]);
    free(mf);
    return TND_OK;
fail:
    for (int r = 0; r < MAP_FILES; r++)
        if (mf->open[r])
            tnd_exr_close(&mf->x[r]);
    free(mf);
    tnd_frame_destroy(f);
    return res;
}
