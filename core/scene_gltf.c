/* core/scene_gltf.c: glTF 2.0 import through assimp's C API, with cJSON for what assimp 5.2 drops
 * or gets wrong: KHR_materials_emissive_strength (ignored by assimp), KHR_materials_volume,
 * exact KHR_lights_punctual values, camera yfov (assimp stores yfov x aspect as a horizontal
 * FOV), STEP interpolation, extensionsRequired, and Tandem's extras (tandem_sky,
 * tandem_light_schedule). Nodes are matched between the two by name; assimp names an unnamed
 * glTF node "nodes[i]". OBJ + MTL and the other formats assimp reads (FBX, Collada, PLY, STL,
 * 3DS) come through assimp alone, their materials converted to metal-rough (docs/scenes.md).
 * Entry points: scene_load_gltf, scene_load_assimp. */
#include "core/core.h"
#include "core/scene_internal.h"

#include <assimp/GltfMaterial.h>
#include <assimp/ObjMaterial.h>
#include <assimp/cimport.h>
#include <assimp/material.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <cjson/cJSON.h>
#include <math.h>
#include <stb/stb_image.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <signal.h>
#include <strings.h>
#include <sys/wait.h>
#include <unistd.h>

/* The glTF extensions Tandem applies: the one list that the checks of extensionsRequired and
 * extensionsUsed and their messages read. */
static const char *const supported_ext[] = {
    "KHR_lights_punctual",        "KHR_materials_emissive_strength",
    "KHR_materials_transmission", "KHR_materials_ior",
    "KHR_materials_volume",       "KHR_materials_specular",
    "KHR_texture_transform",
};
enum { SUPPORTED_EXT_COUNT = sizeof supported_ext / sizeof *supported_ext };

static bool ext_supported(const cJSON *e)
{
    for (size_t i = 0; i < SUPPORTED_EXT_COUNT; i++)
        if (cJSON_IsString(e) && strcmp(e->valuestring, supported_ext[i]) == 0)
            return true;
    return false;
}

typedef struct gltf_ctx {
    const char *path;
    char dir[1024];
    cJSON *json;
    const struct aiScene *ai;
    tnd_scene *s;
    const uint8_t *glb; /* the .glb's bytes (its BIN chunk), NULL for a .gltf */
    size_t glb_size;
    uint8_t **bufs; /* the glTF buffers read so far (buffer_get), nbuf of them */
    size_t *buf_sizes;
    int nbuf;
} gltf_ctx;

/* The JSON text of a .gltf, or the JSON chunk of a .glb. */
static tnd_result parse_json(gltf_ctx *c, const uint8_t *data, size_t size)
{
    const char *text = (const char *)data;
    size_t len = size;
    if (size >= 12 && memcmp(data, "glTF", 4) == 0) {
        uint32_t version, total, clen, ctype;
        memcpy(&version, data + 4, 4);
        memcpy(&total, data + 8, 4);
        if (version != 2 || size < 20)
            return tnd_fail(TND_ERR_BAD_INPUT, "scene: %s: GLB version %u (expected 2)", c->path,
                            version);
        memcpy(&clen, data + 12, 4);
        memcpy(&ctype, data + 16, 4);
        if (ctype != 0x4E4F534Au || (size_t)clen > size - 20 || total > size)
            return tnd_fail(TND_ERR_BAD_INPUT, "scene: %s: truncated or malformed GLB header",
                            c->path);
        text = (const char *)data + 20;
        len = clen;
    }
    c->json = cJSON_ParseWithLength(text, len);
    if (!c->json) {
        const char *at = cJSON_GetErrorPtr();
        long off = at && at >= text && at <= text + len ? (long)(at - text) : -1;
        return tnd_fail(TND_ERR_BAD_INPUT,
                        "scene: %s: invalid glTF JSON (parse error near byte %ld%s)", c->path, off,
                        off >= (long)len - 1 ? ", the file looks truncated" : "");
    }
    const cJSON *asset = cJSON_GetObjectItemCaseSensitive(c->json, "asset");
    const cJSON *ver = asset ? cJSON_GetObjectItemCaseSensitive(asset, "version") : NULL;
    if (!cJSON_IsString(ver) || ver->valuestring[0] != '2')
        return tnd_fail(TND_ERR_BAD_INPUT, "scene: %s: not a glTF 2.0 file (asset.version)",
                        c->path);
    const cJSON *req = cJSON_GetObjectItemCaseSensitive(c->json, "extensionsRequired"), *e;
    cJSON_ArrayForEach(e, req)
    {
        if (ext_supported(e))
            continue;
        char list[512] = "";
        for (size_t i = 0; i < SUPPORTED_EXT_COUNT; i++)
            snprintf(list + strlen(list), sizeof list - strlen(list), "%s%s", i ? ", " : "",
                     supported_ext[i]);
        return tnd_fail(TND_ERR_UNSUPPORTED,
                        "scene: %s: requires extension '%s', which Tandem does not support "
                        "(supported: %s)",
                        c->path, cJSON_IsString(e) ? e->valuestring : "?", list);
    }
    const cJSON *used = cJSON_GetObjectItemCaseSensitive(c->json, "extensionsUsed");
    cJSON_ArrayForEach(e, used)
    {
        if (!ext_supported(e) && cJSON_IsString(e))
            tnd_warn("scene", "%s: extension '%s' is used but ignored", c->path, e->valuestring);
    }
    /* core features Tandem does not model, named once each */
    if (cJSON_GetArraySize(cJSON_GetObjectItemCaseSensitive(c->json, "skins")) > 0)
        tnd_warn("scene", "%s: skinning is not supported: skinned meshes render in their bind pose",
                 c->path);
    const cJSON *jm, *jp;
    bool morph = false;
    cJSON_ArrayForEach(jm, cJSON_GetObjectItemCaseSensitive(c->json, "meshes"))
    {
        cJSON_ArrayForEach(jp, cJSON_GetObjectItemCaseSensitive(jm, "primitives"))
        morph |= cJSON_GetArraySize(cJSON_GetObjectItemCaseSensitive(jp, "targets")) > 0;
    }
    if (morph)
        tnd_warn("scene", "%s: morph targets are not supported: meshes render with their base "
                 "geometry",
                 c->path);
    return TND_OK;
}

/* Copy a name, truncating (names are for messages and lookups of short authored names). */
static void put_name(char *dst, size_t cap, const char *src)
{
    size_t n = strlen(src);
    if (n >= cap)
        n = cap - 1;
    memcpy(dst, src, n);
    dst[n] = '\0';
}

static const cJSON *jget(const cJSON *o, const char *k)
{
    return o ? cJSON_GetObjectItemCaseSensitive(o, k) : NULL;
}

static double jnum(const cJSON *o, const char *k, double def)
{
    const cJSON *v = jget(o, k);
    return cJSON_IsNumber(v) ? v->valuedouble : def;
}

/* A count, offset, length or index member: absent gives def; present, it must be an integer in
 * [0, 2^48) (the one check every number that becomes a size or an address passes). */
static bool jsize(const cJSON *o, const char *k, size_t def, size_t *out)
{
    const cJSON *v = jget(o, k);
    *out = def;
    if (!v)
        return true;
    if (!cJSON_IsNumber(v) || !(v->valuedouble >= 0) || v->valuedouble >= 281474976710656.0 ||
        v->valuedouble != floor(v->valuedouble))
        return false;
    *out = (size_t)v->valuedouble;
    return true;
}

/* The JSON node that assimp calls `name`. */
static const cJSON *json_node(const gltf_ctx *c, const char *name)
{
    const cJSON *nodes = jget(c->json, "nodes");
    int n = cJSON_GetArraySize(nodes);
    for (int i = 0; i < n; i++) {
        const cJSON *nd = cJSON_GetArrayItem(nodes, i);
        const cJSON *nm = jget(nd, "name");
        char alt[32];
        snprintf(alt, sizeof alt, "nodes[%d]", i);
        if ((cJSON_IsString(nm) && strcmp(nm->valuestring, name) == 0) ||
            (!cJSON_IsString(nm) && strcmp(alt, name) == 0))
            return nd;
    }
    return NULL;
}

/* ---- index validation ------------------------------------------------------------------------
 * assimp 5.2 silently drops triangles whose indices are out of range, so the indices are checked
 * here, from the glTF buffers themselves, before assimp sees the file. */
static int b64(int ch)
{
    return ch >= 'A' && ch <= 'Z'   ? ch - 'A'
           : ch >= 'a' && ch <= 'z' ? ch - 'a' + 26
           : ch >= '0' && ch <= '9' ? ch - '0' + 52
           : ch == '+'              ? 62
           : ch == '/'              ? 63
                                    : -1;
}

/* Buffer `b` of the glTF: a file next to it, a base64 data URI, or the GLB's BIN chunk. */
static tnd_result load_buffer(gltf_ctx *c, int b, const uint8_t *glb, size_t glb_size,
                              uint8_t **data, size_t *size)
{
    const cJSON *buf = cJSON_GetArrayItem(jget(c->json, "buffers"), b);
    const cJSON *uri = jget(buf, "uri");
    size_t want = (size_t)jnum(buf, "byteLength", 0);
    *data = NULL;
    *size = 0;
    if (!buf)
        return tnd_fail(TND_ERR_BAD_INPUT, "scene: %s: buffer %d does not exist", c->path, b);
    if (!cJSON_IsString(uri)) { /* GLB binary chunk */
        if (glb && glb_size >= 20) {
            uint32_t jlen;
            memcpy(&jlen, glb + 12, 4);
            size_t off = 20 + (size_t)jlen;
            if (off + 8 <= glb_size) {
                uint32_t blen;
                memcpy(&blen, glb + off, 4);
                if (off + 8 + blen <= glb_size && (*data = malloc(blen ? blen : 1))) {
                    memcpy(*data, glb + off + 8, blen);
                    *size = blen;
                }
            }
        }
        if (!*data)
            return tnd_fail(TND_ERR_BAD_INPUT,
                            "scene: %s: buffer %d has no data (no uri, no GLB "
                            "binary chunk)",
                            c->path, b);
    } else if (strncmp(uri->valuestring, "data:", 5) == 0) {
        const char *comma = strchr(uri->valuestring, ',');
        if (!comma || !strstr(uri->valuestring, ";base64,"))
            return tnd_fail(TND_ERR_BAD_INPUT, "scene: %s: buffer %d: unsupported data URI",
                            c->path, b);
        const char *q = comma + 1;
        size_t len = strlen(q);
        *data = malloc(len / 4 * 3 + 3);
        if (!*data)
            return tnd_fail(TND_ERR_OUT_OF_MEMORY, "scene: out of memory");
        uint32_t acc = 0;
        int bits = 0;
        for (; *q && *q != '='; q++) {
            int v = b64((unsigned char)*q);
            if (v < 0) {
                free(*data);
                *data = NULL;
                return tnd_fail(TND_ERR_BAD_INPUT, "scene: %s: buffer %d: bad base64", c->path, b);
            }
            acc = acc << 6 | (uint32_t)v;
            bits += 6;
            if (bits >= 8) {
                bits -= 8;
                (*data)[(*size)++] = (uint8_t)(acc >> bits);
            }
        }
    } else {
        char full[2048];
        snprintf(full, sizeof full, "%s%s", c->dir, uri->valuestring);
        void *d;
        tnd_result r = tnd_file_read(full, &d, size);
        if (r != TND_OK)
            return tnd_fail(TND_ERR_BAD_INPUT, "scene: %s: buffer %d '%s': cannot open", c->path, b,
                            uri->valuestring);
        *data = d;
    }
    if (*size < want) {
        free(*data);
        *data = NULL;
        return tnd_fail(TND_ERR_BAD_INPUT,
                        "scene: %s: buffer %d: %zu bytes, but byteLength says %zu (truncated?)",
                        c->path, b, *size, want);
    }
    return TND_OK;
}

/* Buffer b, read once and kept until the load ends (buffers_free). */
static tnd_result buffer_get(gltf_ctx *c, int b, const uint8_t **data, size_t *size)
{
    if (!c->bufs) {
        c->nbuf = cJSON_GetArraySize(jget(c->json, "buffers"));
        c->bufs = calloc((size_t)c->nbuf + 1, sizeof *c->bufs);
        c->buf_sizes = calloc((size_t)c->nbuf + 1, sizeof *c->buf_sizes);
        if (!c->bufs || !c->buf_sizes)
            return tnd_fail(TND_ERR_OUT_OF_MEMORY, "scene: out of memory");
    }
    if (b < 0 || b >= c->nbuf)
        return tnd_fail(TND_ERR_BAD_INPUT, "scene: %s: buffer %d does not exist", c->path, b);
    if (!c->bufs[b])
        TND_TRY_RETURN(load_buffer(c, b, c->glb, c->glb_size, &c->bufs[b], &c->buf_sizes[b]));
    *data = c->bufs[b];
    *size = c->buf_sizes[b];
    return TND_OK;
}

static void buffers_free(gltf_ctx *c)
{
    for (int i = 0; c->bufs && i < c->nbuf; i++)
        free(c->bufs[i]);
    free(c->bufs);
    free(c->buf_sizes);
    c->bufs = NULL;
    c->buf_sizes = NULL;
}

/* An accessor's elements where they lie in their buffer, every number checked (jsize) and every
 * element inside its buffer view and the view inside its buffer. */
typedef struct acc_view {
    const uint8_t *p; /* the first element */
    size_t count, stride;
    int ct, comps; /* componentType, components per element */
    size_t csize;  /* bytes per component */
    bool normalized;
} acc_view;

static tnd_result accessor_view(gltf_ctx *c, int index, const char *what, acc_view *v)
{
    static const char *const types[] = {"SCALAR", "VEC2", "VEC3", "VEC4", "MAT2", "MAT3", "MAT4"};
    static const int ncomp[] = {1, 2, 3, 4, 4, 9, 16};
    const cJSON *a = cJSON_GetArrayItem(jget(c->json, "accessors"), index);
    memset(v, 0, sizeof *v);
    if (index < 0 || !a)
        return tnd_fail(TND_ERR_BAD_INPUT, "scene: %s: %s: accessor %d does not exist", c->path,
                        what, index);
    const cJSON *ty = jget(a, "type");
    for (int i = 0; i < 7 && cJSON_IsString(ty); i++)
        if (strcmp(ty->valuestring, types[i]) == 0)
            v->comps = ncomp[i];
    v->ct = (int)jnum(a, "componentType", 0);
    v->csize = v->ct == 5120 || v->ct == 5121 ? 1 : v->ct == 5122 || v->ct == 5123 ? 2
               : v->ct == 5125 || v->ct == 5126                     ? 4
                                                                    : 0;
    v->normalized = cJSON_IsTrue(jget(a, "normalized"));
    size_t aoff, voff, vlen, view, buf, stride;
    const cJSON *bv = NULL;
    bool ok = v->comps && v->csize && jsize(a, "count", 0, &v->count) &&
              jsize(a, "byteOffset", 0, &aoff) && jsize(a, "bufferView", SIZE_MAX, &view) &&
              view != SIZE_MAX && view < (size_t)INT32_MAX &&
              (bv = cJSON_GetArrayItem(jget(c->json, "bufferViews"), (int)view)) &&
              jsize(bv, "byteOffset", 0, &voff) && jsize(bv, "byteLength", 0, &vlen) &&
              jsize(bv, "buffer", SIZE_MAX, &buf) && buf < (size_t)INT32_MAX &&
              jsize(bv, "byteStride", 0, &stride);
    if (!ok)
        return tnd_fail(TND_ERR_BAD_INPUT,
                        "scene: %s: %s: accessor %d: bad type, component type, count, view or "
                        "offset",
                        c->path, what, index);
    size_t elem = v->csize * (size_t)v->comps;
    /* (glTF: a stride is 4 to 252, a multiple of 4; and holds an element) */
    if (stride && (stride < 4 || stride > 252 || stride % 4 || stride < elem))
        return tnd_fail(TND_ERR_BAD_INPUT,
                        "scene: %s: %s: accessor %d: buffer view %zu's byteStride %zu (4 to 252, "
                        "a multiple of 4, at least the element's %zu bytes)",
                        c->path, what, index, view, stride, elem);
    v->stride = stride ? stride : elem;
    const uint8_t *data = NULL;
    size_t size = 0;
    TND_TRY_RETURN(buffer_get(c, (int)buf, &data, &size));
    /* (in this order, so that nothing overflows: the view inside the buffer, the accessor's
     * start inside the view, then its last element by division before multiplication) */
    bool inside = voff <= size && vlen <= size - voff && aoff <= vlen &&
                  (v->count == 0 || ((v->count - 1) <= (vlen - aoff) / v->stride &&
                                     (v->count - 1) * v->stride + elem <= vlen - aoff));
    if (!inside)
        return tnd_fail(TND_ERR_BAD_INPUT,
                        "scene: %s: %s: accessor %d runs past its buffer view or buffer", c->path,
                        what, index);
    v->p = data + voff + aoff;
    return TND_OK;
}

/* Component j of element i as a double (normalised integers mapped as glTF says). */
static double acc_get(const acc_view *v, size_t i, int j)
{
    const uint8_t *p = v->p + i * v->stride + (size_t)j * v->csize;
    switch (v->ct) {
    case 5120: return v->normalized ? fmax((int8_t)p[0] / 127.0, -1.0) : (int8_t)p[0];
    case 5121: return v->normalized ? p[0] / 255.0 : p[0];
    case 5122: {
        int16_t x;
        memcpy(&x, p, 2);
        return v->normalized ? fmax(x / 32767.0, -1.0) : x;
    }
    case 5123: {
        uint16_t x;
        memcpy(&x, p, 2);
        return v->normalized ? x / 65535.0 : x;
    }
    case 5125: {
        uint32_t x;
        memcpy(&x, p, 4);
        return x;
    }
    default: {
        float x;
        memcpy(&x, p, 4);
        return x;
    }
    }
}

/* Every primitive's attributes inside their views and buffers, and its indices naming vertices
 * that exist. */
static tnd_result validate_primitives(gltf_ctx *c)
{
    tnd_result res = TND_OK;
    const cJSON *accs = jget(c->json, "accessors");
    const cJSON *meshes = jget(c->json, "meshes"), *mesh;
    int mi = 0;
    cJSON_ArrayForEach(mesh, meshes)
    {
        const cJSON *nm = jget(mesh, "name"), *prim;
        const char *mname = cJSON_IsString(nm) ? nm->valuestring : "";
        cJSON_ArrayForEach(prim, jget(mesh, "primitives"))
        {
            const cJSON *pa =
                cJSON_GetArrayItem(accs, (int)jnum(jget(prim, "attributes"), "POSITION", -1));
            if (!pa)
                return tnd_fail(TND_ERR_BAD_INPUT,
                                "scene: %s: mesh %d '%s': no POSITION accessor", c->path, mi,
                                mname);
            size_t nverts;
            const cJSON *attr; /* every attribute's elements inside its view and buffer */
            cJSON_ArrayForEach(attr, jget(prim, "attributes"))
            {
                char what[320];
                snprintf(what, sizeof what, "mesh %d '%s': %s", mi, mname,
                         attr->string ? attr->string : "attribute");
                acc_view av;
                if (!cJSON_IsNumber(attr))
                    return tnd_fail(TND_ERR_BAD_INPUT, "scene: %s: %s: not an accessor index",
                                    c->path, what);
                TND_TRY_RETURN(accessor_view(c, (int)attr->valuedouble, what, &av));
            }
            if (!jget(prim, "indices"))
                continue;
            if (!jsize(pa, "count", 0, &nverts))
                return tnd_fail(TND_ERR_BAD_INPUT, "scene: %s: mesh %d '%s': bad POSITION count",
                                c->path, mi, mname);
            char what[320];
            snprintf(what, sizeof what, "mesh %d '%s': indices", mi, mname);
            acc_view v;
            TND_TRY_RETURN(accessor_view(c, (int)jnum(prim, "indices", -1), what, &v));
            if (v.comps != 1 || (v.ct != 5121 && v.ct != 5123 && v.ct != 5125))
                return tnd_fail(TND_ERR_BAD_INPUT,
                                "scene: %s: mesh %d '%s': bad index accessor (component type %d)",
                                c->path, mi, mname, v.ct);
            for (size_t k = 0; k < v.count; k++) {
                double i = acc_get(&v, k, 0);
                if (i >= (double)nverts)
                    return tnd_fail(TND_ERR_BAD_INPUT,
                                    "scene: %s: mesh %d '%s': index %.0f out of range (%zu "
                                    "vertices)",
                                    c->path, mi, mname, i, nverts);
            }
        }
        mi++;
    }
    return res;
}

/* ---- textures ----------------------------------------------------------------------------- */
static int32_t load_texture(gltf_ctx *c, const struct aiMaterial *m, enum aiTextureType type,
                            unsigned index, bool srgb, const char *matname, tnd_result *res)
{
    struct aiString p;
    if (aiGetMaterialTexture(m, type, index, &p, NULL, NULL, NULL, NULL, NULL, NULL) !=
        aiReturn_SUCCESS)
        return -1;
    /* MTL files written on Windows name textures ".\\file.jpg": slashes, no leading "./" */
    for (char *q = p.data; *q; q++)
        if (*q == '\\')
            *q = '/';
    while (p.data[0] == '.' && p.data[1] == '/') {
        memmove(p.data, p.data + 2, strlen(p.data + 2) + 1);
        p.length = (ai_uint32)strlen(p.data);
    }
    tnd_scene *s = c->s;
    for (uint32_t t = 0; t < s->texture_count; t++)
        if (strcmp(s->textures[t].name, p.data) == 0 && s->textures[t].srgb == srgb)
            return (int32_t)t;
    for (uint32_t t = 0; t < s->missing_image_count; t++)
        if (strncmp(s->missing_images[t].name, p.data, sizeof s->missing_images[t].name - 1) == 0) {
            s->missing_images[t].uses++;
            return -1;
        }
    tnd_texture *nt = realloc(s->textures, (s->texture_count + 1) * sizeof *nt);
    if (!nt) {
        *res = tnd_fail(TND_ERR_OUT_OF_MEMORY, "scene: out of memory");
        return -1;
    }
    s->textures = nt;
    tnd_texture *tx = &s->textures[s->texture_count];
    memset(tx, 0, sizeof *tx);
    put_name(tx->name, sizeof tx->name, p.data);
    tx->srgb = srgb;
    int w = 0, h = 0, n = 0;
    uint8_t *px = NULL;
    char full[2048];
    if (p.data[0] == '*') { /* embedded: "*N" */
        unsigned k = (unsigned)atoi(p.data + 1);
        if (k < c->ai->mNumTextures) {
            const struct aiTexture *at = c->ai->mTextures[k];
            if (at->mHeight == 0)
                px = stbi_load_from_memory((const uint8_t *)at->pcData, (int)at->mWidth, &w, &h, &n,
                                           4);
        }
        snprintf(full, sizeof full, "embedded texture %s", p.data);
    } else {
        snprintf(full, sizeof full, "%s%s", c->dir, p.data);
        px = stbi_load(full, &w, &h, &n, 4);
    }
    if (!px) { /* named once, and the material keeps its factors (docs/scenes.md) */
        const char *why = stbi_failure_reason() ? stbi_failure_reason() : "unreadable";
        if (p.data[0] != '*' && access(full, F_OK) != 0)
            why = strncmp(p.data, "Procedural,", 11) == 0 ? "a Blender procedural texture, not an image"
                                                          : "no such file";
        struct tnd_missing_image *mi =
            realloc(s->missing_images, (s->missing_image_count + 1) * sizeof *mi);
        if (!mi) {
            *res = tnd_fail(TND_ERR_OUT_OF_MEMORY, "scene: out of memory");
            return -1;
        }
        s->missing_images = mi;
        mi += s->missing_image_count++;
        memset(mi, 0, sizeof *mi);
        put_name(mi->name, sizeof mi->name, p.data);
        put_name(mi->material, sizeof mi->material, matname);
        put_name(mi->reason, sizeof mi->reason, why);
        mi->uses = 1;
        tnd_warn("scene",
                 "%s: material '%s': texture '%s': %s: left out (the material's factors alone: %s)",
                 c->path, matname, full, why,
                 type == aiTextureType_NORMALS || type == aiTextureType_HEIGHT ? "a flat normal"
                                                                                : "no texture");
        return -1;
    }
    tx->width = (uint32_t)w;
    tx->height = (uint32_t)h;
    tx->rgba8 = px; /* stbi allocates with malloc */
    return (int32_t)s->texture_count++;
}

/* One material per assimp material, each glTF's defaults (tnd_material_default) under its
 * name; the loaders fill in the rest. */
static tnd_result alloc_materials(gltf_ctx *c)
{
    tnd_scene *s = c->s;
    const struct aiScene *ai = c->ai;
    s->material_count = ai->mNumMaterials;
    s->materials = calloc(s->material_count ? s->material_count : 1, sizeof *s->materials);
    if (!s->materials)
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "scene: %s: out of memory", c->path);
    for (uint32_t i = 0; i < ai->mNumMaterials; i++) {
        tnd_material *m = &s->materials[i];
        *m = tnd_material_default("");
        struct aiString nm;
        if (aiGetMaterialString(ai->mMaterials[i], AI_MATKEY_NAME, &nm) == aiReturn_SUCCESS)
            put_name(m->name, sizeof m->name, nm.data);
    }
    return TND_OK;
}

/* A textureInfo's texCoord and KHR_texture_transform (offset, rotation, scale, texCoord) as one
 * affine map, T(offset) R(rotation) S(scale) with R = [cos sin; -sin cos] (the extension's). */
static tnd_result parse_uv_xform(const gltf_ctx *c, uint32_t mi, const char *mname,
                                 const cJSON *info, tnd_uv_xform *x)
{
    *x = (tnd_uv_xform)TND_UV_IDENTITY;
    if (!info)
        return TND_OK;
    double set = jnum(info, "texCoord", 0);
    const cJSON *tt = jget(jget(info, "extensions"), "KHR_texture_transform");
    double off[2] = {0, 0}, sc[2] = {1, 1}, rot = jnum(tt, "rotation", 0);
    const cJSON *o = jget(tt, "offset"), *s = jget(tt, "scale");
    for (int k = 0; k < 2; k++) {
        if (cJSON_GetArraySize(o) == 2)
            off[k] = cJSON_GetArrayItem(o, k)->valuedouble;
        if (cJSON_GetArraySize(s) == 2)
            sc[k] = cJSON_GetArrayItem(s, k)->valuedouble;
    }
    if (jget(tt, "texCoord"))
        set = jnum(tt, "texCoord", set);
    if (!(set == 0 || set == 1) || !isfinite(off[0] + off[1] + sc[0] + sc[1] + rot))
        return tnd_fail(TND_ERR_BAD_INPUT,
                        "scene: %s: material %u '%s': texture coordinates: texCoord %g (Tandem "
                        "reads TEXCOORD_0 and _1) or a non-finite KHR_texture_transform",
                        c->path, mi, mname, set);
    double cr = cos(rot), sr = sin(rot);
    x->m[0] = (float)(cr * sc[0]), x->m[1] = (float)(sr * sc[1]), x->m[2] = (float)off[0];
    x->m[3] = (float)(-sr * sc[0]), x->m[4] = (float)(cr * sc[1]), x->m[5] = (float)off[1];
    x->set = (uint32_t)set;
    double det = fabs(sc[0] * sc[1]);
    x->lod_shift = det > 0 ? (float)(0.5 * log2(det)) : 0.0f;
    return TND_OK;
}

static tnd_result load_materials(gltf_ctx *c)
{
    tnd_result res = TND_OK;
    tnd_scene *s = c->s;
    const struct aiScene *ai = c->ai;
    TND_TRY_RETURN(alloc_materials(c));
    const cJSON *jmats = jget(c->json, "materials");
    for (uint32_t i = 0; i < ai->mNumMaterials; i++) {
        const struct aiMaterial *am = ai->mMaterials[i];
        tnd_material *m = &s->materials[i];
        float v4[4] = {1, 1, 1, 1};
        unsigned n = 4;
        if (aiGetMaterialFloatArray(am, AI_MATKEY_BASE_COLOR, v4, &n) != aiReturn_SUCCESS) {
            n = 4;
            aiGetMaterialFloatArray(am, AI_MATKEY_COLOR_DIFFUSE, v4, &n);
        }
        memcpy(m->base_color, v4, sizeof v4);
        m->metallic = 1.0f;
        m->roughness = 1.0f;
        n = 1;
        aiGetMaterialFloatArray(am, AI_MATKEY_METALLIC_FACTOR, &m->metallic, &n);
        n = 1;
        aiGetMaterialFloatArray(am, AI_MATKEY_ROUGHNESS_FACTOR, &m->roughness, &n);
        float em[3] = {0, 0, 0};
        n = 3;
        aiGetMaterialFloatArray(am, AI_MATKEY_COLOR_EMISSIVE, em, &n);
        int two = 0;
        n = 1;
        aiGetMaterialIntegerArray(am, AI_MATKEY_TWOSIDED, &two, &n);
        m->double_sided = two != 0;
        m->ior = 1.5f;
        m->normal_scale = 1.0f;
        m->attenuation_color[0] = m->attenuation_color[1] = m->attenuation_color[2] = 1.0f;
        /* The JSON material of the same name (assimp reorders materials and appends a default
         * one); unnamed glTF materials are matched by index. Its extensions are read here. */
        const cJSON *jm = NULL, *it;
        cJSON_ArrayForEach(it, jmats)
        {
            const cJSON *jn = jget(it, "name");
            if (!jm && cJSON_IsString(jn) && strcmp(jn->valuestring, m->name) == 0)
                jm = it;
        }
        if (!jm && !cJSON_IsString(jget(cJSON_GetArrayItem(jmats, (int)i), "name")))
            jm = cJSON_GetArrayItem(jmats, (int)i);
        float strength = 1.0f;
        const cJSON *ext = jget(jm, "extensions");
        const cJSON *es = jget(ext, "KHR_materials_emissive_strength");
        strength = (float)jnum(es, "emissiveStrength", 1.0);
        for (int k = 0; k < 3; k++)
            m->emission[k] = em[k] * strength;
        const cJSON *tr = jget(ext, "KHR_materials_transmission");
        m->transmission = (float)jnum(tr, "transmissionFactor", 0.0);
        m->ior = (float)jnum(jget(ext, "KHR_materials_ior"), "ior", 1.5);
        m->specular = (float)jnum(jget(ext, "KHR_materials_specular"), "specularFactor", 1.0);
        const cJSON *vol = jget(ext, "KHR_materials_volume");
        if (vol) {
            m->thickness = (float)jnum(vol, "thicknessFactor", 0.0);
            m->attenuation_distance = (float)jnum(vol, "attenuationDistance", 0.0);
            const cJSON *ac = jget(vol, "attenuationColor");
            for (int k = 0; k < 3 && cJSON_GetArraySize(ac) == 3; k++)
                m->attenuation_color[k] = (float)cJSON_GetArrayItem(ac, k)->valuedouble;
        }
        m->normal_scale = (float)jnum(jget(jm, "normalTexture"), "scale", 1.0);
        /* each texture's coordinate set and KHR_texture_transform */
        const cJSON *pbr = jget(jm, "pbrMetallicRoughness");
        const cJSON *infos[TND_TEX_SLOTS] = {
            jget(pbr, "baseColorTexture"), jget(pbr, "metallicRoughnessTexture"),
            jget(jm, "normalTexture"), jget(jm, "emissiveTexture")};
        for (int k = 0; k < TND_TEX_SLOTS; k++) {
            tnd_result xr = parse_uv_xform(c, i, m->name, infos[k], &m->uvx[k]);
            if (xr != TND_OK)
                return xr;
        }
        /* alphaMode: MASK cuts at alphaCutoff (default 0.5); BLEND is taken as a cut-out at
         * 0.5 (docs/scenes.md says why); OPAQUE, the default, ignores alpha */
        const cJSON *am_mode = jget(jm, "alphaMode");
        const char *mode = cJSON_IsString(am_mode) ? am_mode->valuestring : "OPAQUE";
        if (strcmp(mode, "MASK") == 0 || strcmp(mode, "BLEND") == 0) {
            m->alpha_test = true;
            m->alpha_cutoff = mode[0] == 'M' ? (float)jnum(jm, "alphaCutoff", 0.5) : 0.5f;
        } else if (strcmp(mode, "OPAQUE") != 0) {
            return tnd_fail(TND_ERR_BAD_INPUT,
                            "scene: %s: material %u '%s': alphaMode '%s' (expected OPAQUE, MASK "
                            "or BLEND)",
                            c->path, i, m->name, mode);
        }
        if (m->alpha_test && !(m->alpha_cutoff >= 0.0f && m->alpha_cutoff <= 1.0f))
            return tnd_fail(TND_ERR_BAD_INPUT,
                            "scene: %s: material %u '%s': alphaCutoff %g outside [0, 1]", c->path,
                            i, m->name, (double)m->alpha_cutoff);
        bool finite = true;
        const float *vals[] = {m->base_color, m->emission, &m->metallic, &m->roughness, &m->ior};
        const int counts[] = {4, 3, 1, 1, 1};
        for (int a = 0; a < 5; a++)
            for (int k = 0; k < counts[a]; k++)
                finite &= isfinite(vals[a][k]);
        finite &= isfinite(m->specular) && m->specular >= 0.0f;
        if (!finite || m->ior < 1.0f || m->ior > 5.0f)
            return tnd_fail(TND_ERR_BAD_INPUT,
                            "scene: %s: material %u '%s': non-finite factor or IOR %g outside "
                            "[1, 5]",
                            c->path, i, m->name, (double)m->ior);
        m->metallic = fminf(fmaxf(m->metallic, 0.0f), 1.0f);
        m->roughness = fminf(fmaxf(m->roughness, 0.0f), 1.0f);
        m->tex_base_color = load_texture(c, am, aiTextureType_BASE_COLOR, 0, true, m->name, &res);
        if (res != TND_OK)
            return res;
        if (m->tex_base_color < 0)
            m->tex_base_color = load_texture(c, am, aiTextureType_DIFFUSE, 0, true, m->name, &res);
        if (res != TND_OK)
            return res;
        m->tex_metal_rough =
            load_texture(c, am, AI_MATKEY_GLTF_PBRMETALLICROUGHNESS_METALLICROUGHNESS_TEXTURE,
                         false, m->name, &res);
        if (res != TND_OK)
            return res;
        m->tex_normal = load_texture(c, am, aiTextureType_NORMALS, 0, false, m->name, &res);
        if (res != TND_OK)
            return res;
        m->tex_emission = load_texture(c, am, aiTextureType_EMISSIVE, 0, true, m->name, &res);
        if (res != TND_OK)
            return res;
        m->kind = scene_classify(m);
    }
    return TND_OK;
}

static tnd_result load_meshes(gltf_ctx *c)
{
    tnd_scene *s = c->s;
    const struct aiScene *ai = c->ai;
    uint64_t nv = 0, ni = 0;
    for (unsigned i = 0; i < ai->mNumMeshes; i++) {
        nv += ai->mMeshes[i]->mNumVertices;
        ni += 3ull * ai->mMeshes[i]->mNumFaces;
    }
    if (nv > UINT32_MAX || ni > UINT32_MAX)
        return tnd_fail(TND_ERR_LIMIT, "scene: %s: too many vertices or indices", c->path);
    s->positions = calloc(nv * 3 + 3, sizeof(float));
    s->normals = calloc(nv * 3 + 3, sizeof(float));
    s->uvs = calloc(nv * 2 + 2, sizeof(float));
    bool set1 = false;
    for (unsigned i = 0; i < ai->mNumMeshes; i++)
        set1 |= ai->mMeshes[i]->mTextureCoords[1] != NULL;
    if (set1 && !(s->uvs1 = calloc(nv * 2 + 2, sizeof(float))))
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "scene: %s: out of memory", c->path);
    s->tangents = calloc(nv * 4 + 4, sizeof(float));
    s->indices = calloc(ni + 3, sizeof(uint32_t));
    s->meshes = calloc(ai->mNumMeshes + 1, sizeof *s->meshes);
    if (!s->positions || !s->normals || !s->uvs || !s->tangents || !s->indices || !s->meshes)
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "scene: %s: out of memory", c->path);
    uint32_t v = 0, ix = 0;
    for (unsigned i = 0; i < ai->mNumMeshes; i++) {
        const struct aiMesh *am = ai->mMeshes[i];
        tnd_mesh *me = &s->meshes[i];
        put_name(me->name, sizeof me->name, am->mName.data);
        me->first_vertex = v;
        me->vertex_count = am->mNumVertices;
        me->first_index = ix;
        me->material = am->mMaterialIndex;
        for (unsigned k = 0; k < am->mNumVertices; k++) {
            float *p = s->positions + 3 * (size_t)(v + k), *n = s->normals + 3 * (size_t)(v + k);
            p[0] = am->mVertices[k].x, p[1] = am->mVertices[k].y, p[2] = am->mVertices[k].z;
            if (am->mNormals)
                n[0] = am->mNormals[k].x, n[1] = am->mNormals[k].y, n[2] = am->mNormals[k].z;
            if (am->mTextureCoords[0]) {
                s->uvs[2 * (size_t)(v + k)] = am->mTextureCoords[0][k].x;
                /* assimp flips V for glTF (aiProcess_FlipUVs not set): undo to glTF's top-left */
                s->uvs[2 * (size_t)(v + k) + 1] = 1.0f - am->mTextureCoords[0][k].y;
            }
            if (s->uvs1) { /* TEXCOORD_1 (a mesh without one reads set 0 there) */
                const struct aiVector3D *t1 =
                    am->mTextureCoords[1] ? am->mTextureCoords[1] : am->mTextureCoords[0];
                s->uvs1[2 * (size_t)(v + k)] = t1 ? t1[k].x : 0.0f;
                s->uvs1[2 * (size_t)(v + k) + 1] = t1 ? 1.0f - t1[k].y : 0.0f;
            }
            float *t = s->tangents + 4 * (size_t)(v + k);
            if (am->mTangents && am->mBitangents) {
                const struct aiVector3D T = am->mTangents[k], B = am->mBitangents[k];
                t[0] = T.x, t[1] = T.y, t[2] = T.z;
                /* handedness: sign of dot(cross(N, T), B) */
                float cx = n[1] * T.z - n[2] * T.y, cy = n[2] * T.x - n[0] * T.z,
                      cz = n[0] * T.y - n[1] * T.x;
                t[3] = cx * B.x + cy * B.y + cz * B.z < 0 ? -1.0f : 1.0f;
            } else {
                t[0] = 1, t[3] = 1;
            }
        }
        for (unsigned f = 0; f < am->mNumFaces; f++) {
            const struct aiFace *fc = &am->mFaces[f];
            if (fc->mNumIndices != 3)
                continue; /* points and lines are not rendered */
            for (int k = 0; k < 3; k++)
                s->indices[ix++] = fc->mIndices[k];
        }
        me->triangle_count = (ix - me->first_index) / 3;
        v += am->mNumVertices;
    }
    s->vertex_count = v;
    s->index_count = ix;
    s->mesh_count = ai->mNumMeshes;
    return TND_OK;
}

/* Depth-first, parents before children. */
static tnd_result add_node(gltf_ctx *c, const struct aiNode *an, int32_t parent, uint32_t *cap)
{
    tnd_scene *s = c->s;
    if (s->node_count == *cap) {
        *cap = *cap ? *cap * 2 : 64;
        tnd_node *nn = realloc(s->nodes, *cap * sizeof *nn);
        if (!nn)
            return tnd_fail(TND_ERR_OUT_OF_MEMORY, "scene: out of memory");
        s->nodes = nn;
    }
    uint32_t me = s->node_count++;
    tnd_node *nd = &s->nodes[me];
    memset(nd, 0, sizeof *nd);
    put_name(nd->name, sizeof nd->name, an->mName.data);
    nd->parent = parent;
    struct aiVector3D sc, pos;
    struct aiQuaternion q;
    aiDecomposeMatrix(&an->mTransformation, &sc, &q, &pos);
    nd->t[0] = pos.x, nd->t[1] = pos.y, nd->t[2] = pos.z;
    nd->r[0] = q.x, nd->r[1] = q.y, nd->r[2] = q.z, nd->r[3] = q.w;
    nd->s[0] = sc.x, nd->s[1] = sc.y, nd->s[2] = sc.z;
    for (unsigned k = 0; k < an->mNumMeshes; k++) {
        if (an->mMeshes[k] >= c->ai->mNumMeshes)
            return tnd_fail(TND_ERR_BAD_INPUT, "scene: %s: node '%s': mesh %u of %u", c->path,
                            nd->name, an->mMeshes[k], c->ai->mNumMeshes);
        if (s->meshes[an->mMeshes[k]].triangle_count == 0)
            continue;
        tnd_instance *ni = realloc(s->instances, (s->instance_count + 1) * sizeof *ni);
        if (!ni)
            return tnd_fail(TND_ERR_OUT_OF_MEMORY, "scene: out of memory");
        s->instances = ni;
        s->instances[s->instance_count++] = (tnd_instance){an->mMeshes[k], me, false};
    }
    for (unsigned k = 0; k < an->mNumChildren; k++) {
        tnd_result r = add_node(c, an->mChildren[k], (int32_t)me, cap);
        if (r != TND_OK)
            return r;
    }
    return TND_OK;
}

static int32_t node_index(const tnd_scene *s, const char *name)
{
    for (uint32_t i = 0; i < s->node_count; i++)
        if (strcmp(s->nodes[i].name, name) == 0)
            return (int32_t)i;
    return -1;
}

static tnd_result load_cameras_lights(gltf_ctx *c)
{
    tnd_scene *s = c->s;
    const struct aiScene *ai = c->ai;
    s->cameras = calloc(ai->mNumCameras + 1, sizeof *s->cameras);
    s->lights = calloc(ai->mNumLights + 1, sizeof *s->lights);
    if (!s->cameras || !s->lights)
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "scene: out of memory");
    const cJSON *jcams = jget(c->json, "cameras");
    for (unsigned i = 0; i < ai->mNumCameras; i++) {
        const struct aiCamera *ac = ai->mCameras[i];
        int32_t n = node_index(s, ac->mName.data);
        if (n < 0)
            continue;
        tnd_camera_def *cd = &s->cameras[s->camera_count++];
        put_name(cd->name, sizeof cd->name, ac->mName.data);
        cd->node = (uint32_t)n;
        cd->aspect = ac->mAspect;
        cd->znear = ac->mClipPlaneNear > 0 ? ac->mClipPlaneNear : 0.05f;
        cd->zfar = 0.0f;
        cd->yfov = ac->mAspect > 0 ? ac->mHorizontalFOV / ac->mAspect : ac->mHorizontalFOV;
        const cJSON *jn = json_node(c, ac->mName.data);
        const cJSON *jc = cJSON_GetArrayItem(jcams, (int)jnum(jn, "camera", -1));
        const cJSON *pp = jget(jc, "perspective");
        if (pp) {
            cd->yfov = (float)jnum(pp, "yfov", cd->yfov);
            cd->znear = (float)jnum(pp, "znear", cd->znear);
            cd->zfar = (float)jnum(pp, "zfar", 0.0);
            cd->aspect = (float)jnum(pp, "aspectRatio", 0.0);
        } else if (jc) { /* orthographic: left out, the scene keeps its other cameras */
            tnd_warn("scene", "%s: camera '%s' is orthographic and is ignored (Tandem renders "
                     "perspective cameras)", c->path, cd->name);
            s->camera_count--;
            continue;
        }
        if (!(cd->yfov > 1e-4f && cd->yfov < 3.1f) || !(cd->znear > 0))
            return tnd_fail(TND_ERR_BAD_INPUT, "scene: %s: camera '%s': yfov %g, znear %g", c->path,
                            cd->name, (double)cd->yfov, (double)cd->znear);
    }
    const cJSON *jlights = jget(jget(jget(c->json, "extensions"), "KHR_lights_punctual"), "lights");
    for (unsigned i = 0; i < ai->mNumLights; i++) {
        const struct aiLight *al = ai->mLights[i];
        int32_t n = node_index(s, al->mName.data);
        if (n < 0)
            continue;
        tnd_light *l = &s->lights[s->light_count];
        put_name(l->name, sizeof l->name, al->mName.data);
        l->node = (uint32_t)n;
        switch (al->mType) {
        case aiLightSource_DIRECTIONAL:
            l->type = TND_LIGHT_DIRECTIONAL;
            break;
        case aiLightSource_POINT:
            l->type = TND_LIGHT_POINT;
            break;
        case aiLightSource_SPOT:
            l->type = TND_LIGHT_SPOT;
            break;
        default:
            tnd_warn("scene", "%s: light '%s' of unsupported type %d ignored", c->path, l->name,
                     (int)al->mType);
            continue;
        }
        l->color[0] = al->mColorDiffuse.r, l->color[1] = al->mColorDiffuse.g;
        l->color[2] = al->mColorDiffuse.b;
        l->inner_cone = al->mAngleInnerCone;
        l->outer_cone = al->mAngleOuterCone;
        /* exact glTF values where the JSON has them */
        const cJSON *jn = json_node(c, l->name);
        const cJSON *lref = jget(jget(jn, "extensions"), "KHR_lights_punctual");
        const cJSON *jl = cJSON_GetArrayItem(jlights, (int)jnum(lref, "light", -1));
        if (jl) {
            double inten = jnum(jl, "intensity", 1.0);
            const cJSON *col = jget(jl, "color");
            for (int k = 0; k < 3; k++)
                l->color[k] =
                    (float)((cJSON_GetArraySize(col) == 3 ? cJSON_GetArrayItem(col, k)->valuedouble
                                                          : 1.0) *
                            inten);
            const cJSON *spot = jget(jl, "spot");
            l->inner_cone = (float)jnum(spot, "innerConeAngle", 0.0);
            l->outer_cone = (float)jnum(spot, "outerConeAngle", TND_PI / 4);
        }
        if (!isfinite(l->color[0]) || !isfinite(l->color[1]) || !isfinite(l->color[2]) ||
            l->color[0] < 0 || l->color[1] < 0 || l->color[2] < 0)
            return tnd_fail(TND_ERR_BAD_INPUT,
                            "scene: %s: light '%s': intensity not finite and "
                            "non-negative",
                            c->path, l->name);
        if (l->type == TND_LIGHT_SPOT &&
            !(l->outer_cone > l->inner_cone && l->outer_cone <= TND_PI / 2))
            return tnd_fail(TND_ERR_BAD_INPUT,
                            "scene: %s: light '%s': spot cone angles %g..%g (need inner < outer "
                            "<= pi/2)",
                            c->path, l->name, (double)l->inner_cone, (double)l->outer_cone);
        const cJSON *sched = jget(jget(jn, "extras"), "tandem_light_schedule");
        if (sched) {
            const cJSON *keys = jget(sched, "keys"), *k;
            l->schedule_fps = (float)jnum(sched, "fps", 30.0);
            cJSON_ArrayForEach(k, keys)
            {
                if (l->schedule_count == TND_SCHEDULE_MAX || cJSON_GetArraySize(k) != 2)
                    return tnd_fail(TND_ERR_BAD_INPUT,
                                    "scene: %s: light '%s': tandem_light_schedule keys must be "
                                    "[frame, scale] pairs (at most %d)",
                                    c->path, l->name, TND_SCHEDULE_MAX);
                l->schedule_frame[l->schedule_count] = (float)cJSON_GetArrayItem(k, 0)->valuedouble;
                l->schedule_scale[l->schedule_count++] =
                    (float)cJSON_GetArrayItem(k, 1)->valuedouble;
            }
        }
        s->light_count++;
    }
    const cJSON *scenes = jget(c->json, "scenes");
    const cJSON *sc = cJSON_GetArrayItem(scenes, (int)jnum(c->json, "scene", 0));
    const cJSON *sky = jget(jget(sc, "extras"), "tandem_sky");
    if (cJSON_GetArraySize(sky) == 3) {
        for (int k = 0; k < 3; k++)
            s->sky[k] = (float)cJSON_GetArrayItem(sky, k)->valuedouble;
        s->sky_set = true;
    }
    const cJSON *env = jget(jget(sc, "extras"), "tandem_env");
    if (env) {
        const cJSON *uri = jget(env, "uri");
        if (!cJSON_IsObject(env) || !cJSON_IsString(uri))
            return tnd_fail(TND_ERR_BAD_INPUT,
                            "scene: %s: scene extras tandem_env: expected {\"uri\": \"file.exr\", "
                            "\"intensity\": 1, \"rotation\": degrees}",
                            c->path);
        char path[2048];
        if (uri->valuestring[0] == '/')
            snprintf(path, sizeof path, "%s", uri->valuestring);
        else
            snprintf(path, sizeof path, "%s%s", c->dir, uri->valuestring);
        tnd_result r = tnd_env_load(path, (float)jnum(env, "intensity", 1.0),
                                    (float)jnum(env, "rotation", 0.0), &s->env);
        if (r != TND_OK) {
            char why[1024];
            snprintf(why, sizeof why, "%s", tnd_error_detail());
            return tnd_fail(r, "scene: %s: scene extras tandem_env: %s", c->path, why);
        }
    }
    return TND_OK;
}

/* The glTF sampler animating (node, path), or NULL. */
static const cJSON *json_sampler(const gltf_ctx *c, const char *node, const char *path)
{
    const cJSON *anims = jget(c->json, "animations"), *a;
    const cJSON *nodes = jget(c->json, "nodes");
    cJSON_ArrayForEach(a, anims)
    {
        const cJSON *ch, *samplers = jget(a, "samplers");
        cJSON_ArrayForEach(ch, jget(a, "channels"))
        {
            const cJSON *tg = jget(ch, "target");
            const cJSON *pth = jget(tg, "path");
            int ni = (int)jnum(tg, "node", -1);
            if (!cJSON_IsString(pth) || strcmp(pth->valuestring, path) != 0 || ni < 0)
                continue;
            if (json_node(c, node) != cJSON_GetArrayItem(nodes, ni))
                continue;
            return cJSON_GetArrayItem(samplers, (int)jnum(ch, "sampler", -1));
        }
    }
    return NULL;
}

/* A CUBICSPLINE sampler's keys read from the file itself (assimp 5.2 keeps the values and drops
 * the tangents): its input times and its output's in-tangent, value, out-tangent triples. */
static tnd_result load_cubic(gltf_ctx *c, const cJSON *smp, const char *node, tnd_anim_channel *ch)
{
    uint32_t dim = tnd_anim_dim(ch->path);
    char what[160];
    snprintf(what, sizeof what, "animation of node '%s': CUBICSPLINE sampler", node);
    acc_view in, out;
    TND_TRY_RETURN(accessor_view(c, (int)jnum(smp, "input", -1), what, &in));
    TND_TRY_RETURN(accessor_view(c, (int)jnum(smp, "output", -1), what, &out));
    if (in.comps != 1 || (uint32_t)out.comps != dim || in.count == 0 ||
        out.count != 3 * in.count || in.count > UINT32_MAX / 4)
        return tnd_fail(TND_ERR_BAD_INPUT,
                        "scene: %s: %s: %zu keys need 3 x %zu outputs of %u components (it has "
                        "%zu of %d)",
                        c->path, what, in.count, in.count, dim, out.count, out.comps);
    float *times = malloc(in.count * sizeof *times);
    float *vals = malloc(out.count * dim * sizeof *vals);
    if (!times || !vals) {
        free(times);
        free(vals);
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "scene: out of memory");
    }
    for (size_t k = 0; k < in.count; k++)
        times[k] = (float)acc_get(&in, k, 0);
    for (size_t k = 0; k < out.count; k++)
        for (uint32_t d = 0; d < dim; d++)
            vals[k * dim + d] = (float)acc_get(&out, k, (int)d);
    free(ch->times);
    free(ch->values);
    ch->times = times;
    ch->values = vals;
    ch->key_count = (uint32_t)in.count;
    ch->cubic = true;
    for (size_t k = 0; k < in.count; k++)
        for (uint32_t d = 0; d < 3 * dim; d++)
            if (!isfinite(times[k]) || !isfinite(vals[3 * dim * k + d]) ||
                (k > 0 && !(times[k] > times[k - 1])))
                return tnd_fail(TND_ERR_BAD_INPUT,
                                "scene: %s: %s: key %zu is not finite or out of order", c->path,
                                what, k);
    return TND_OK;
}

static tnd_result load_animation(gltf_ctx *c)
{
    tnd_scene *s = c->s;
    const struct aiScene *ai = c->ai;
    uint32_t cap = 0;
    for (unsigned a = 0; a < ai->mNumAnimations; a++)
        cap += 3 * ai->mAnimations[a]->mNumChannels;
    s->channels = calloc(cap + 1, sizeof *s->channels);
    if (!s->channels)
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "scene: out of memory");
    for (unsigned a = 0; a < ai->mNumAnimations; a++) {
        const struct aiAnimation *an = ai->mAnimations[a];
        double tps = an->mTicksPerSecond > 0 ? an->mTicksPerSecond : 1000.0;
        for (unsigned k = 0; k < an->mNumChannels; k++) {
            const struct aiNodeAnim *na = an->mChannels[k];
            int32_t n = node_index(s, na->mNodeName.data);
            if (n < 0)
                continue;
            const tnd_node *nd = &s->nodes[n];
            for (int path = 0; path < 3; path++) {
                unsigned count = path == 0   ? na->mNumPositionKeys
                                 : path == 1 ? na->mNumRotationKeys
                                             : na->mNumScalingKeys;
                int dim = path == 1 ? 4 : 3;
                if (count == 0)
                    continue;
                tnd_anim_channel *ch = &s->channels[s->channel_count];
                ch->node = (uint32_t)n;
                ch->path = (tnd_anim_path)path;
                ch->times = calloc(count, sizeof(float));
                ch->values = calloc((size_t)count * dim, sizeof(float));
                if (!ch->times || !ch->values) {
                    free(ch->times);
                    free(ch->values);
                    return tnd_fail(TND_ERR_OUT_OF_MEMORY, "scene: out of memory");
                }
                ch->key_count = count;
                bool constant = true;
                for (unsigned q = 0; q < count; q++) {
                    float *v = ch->values + (size_t)dim * q;
                    if (path == 0) {
                        ch->times[q] = (float)(na->mPositionKeys[q].mTime / tps);
                        v[0] = na->mPositionKeys[q].mValue.x, v[1] = na->mPositionKeys[q].mValue.y;
                        v[2] = na->mPositionKeys[q].mValue.z;
                    } else if (path == 1) {
                        ch->times[q] = (float)(na->mRotationKeys[q].mTime / tps);
                        const struct aiQuaternion *qq = &na->mRotationKeys[q].mValue;
                        v[0] = qq->x, v[1] = qq->y, v[2] = qq->z, v[3] = qq->w;
                    } else {
                        ch->times[q] = (float)(na->mScalingKeys[q].mTime / tps);
                        v[0] = na->mScalingKeys[q].mValue.x, v[1] = na->mScalingKeys[q].mValue.y;
                        v[2] = na->mScalingKeys[q].mValue.z;
                    }
                    const float *rest = path == 0 ? nd->t : path == 1 ? nd->r : nd->s;
                    for (int d = 0; d < dim; d++)
                        constant &= fabsf(v[d] - rest[d]) < 1e-6f;
                    for (int d = 0; d < dim; d++)
                        if (!isfinite(v[d]) || !isfinite(ch->times[q]) ||
                            (q > 0 && ch->times[q] < ch->times[q - 1])) {
                            free(ch->times);
                            free(ch->values);
                            ch->times = NULL;
                            ch->values = NULL;
                            return tnd_fail(TND_ERR_BAD_INPUT,
                                            "scene: %s: animation of node '%s': key %u is not "
                                            "finite or out of order",
                                            c->path, nd->name, q);
                        }
                }
                if (constant) { /* assimp adds one-key channels for untouched paths */
                    free(ch->times);
                    free(ch->values);
                    memset(ch, 0, sizeof *ch);
                    continue;
                }
                static const char *const names[3] = {"translation", "rotation", "scale"};
                const cJSON *smp = json_sampler(c, nd->name, names[path]);
                const cJSON *ip = jget(smp, "interpolation");
                ch->step = cJSON_IsString(ip) && strcmp(ip->valuestring, "STEP") == 0;
                s->channel_count++; /* (freed with the scene from here on) */
                if (cJSON_IsString(ip) && strcmp(ip->valuestring, "CUBICSPLINE") == 0)
                    TND_TRY_RETURN(load_cubic(c, smp, nd->name, ch));
            }
        }
    }
    return TND_OK;
}

/* A context for `path`: its scene allocated and named, the directory relative names are read
 * from. */
static tnd_result ctx_begin(gltf_ctx *c, const char *path)
{
    memset(c, 0, sizeof *c);
    c->path = path;
    c->s = calloc(1, sizeof *c->s);
    if (!c->s)
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "scene: out of memory");
    snprintf(c->s->path, sizeof c->s->path, "%s", path);
    const char *slash = strrchr(path, '/');
    if (slash)
        snprintf(c->dir, sizeof c->dir, "%.*s/", (int)(slash - path), path);
    return TND_OK;
}

/* assimp's import flags: triangulated with smooth normals and tangents (plus `flags`) */
static unsigned import_flags(unsigned flags)
{
    return aiProcess_Triangulate | aiProcess_CalcTangentSpace | aiProcess_GenSmoothNormals |
           aiProcess_ValidateDataStructure | flags;
}

/* The formats Tandem does not pre-parse (OBJ and MTL, FBX, ...) are imported once in a child
 * process first: assimp 5.2.5's OBJ/MTL parser dereferences wild pointers on some malformed
 * files (found by tests/fuzz/fuzz_obj), which would take Tandem down with it. A crash of the
 * child refuses the file by name; a child that could not be made leaves the import as it was.
 * (glTF is checked by Tandem's own pre-pass: JSON, buffers, accessors, indices.) */
static tnd_result probe_import(const char *path, unsigned flags)
{
    fflush(NULL);
    pid_t pid = fork();
    if (pid < 0)
        return TND_OK;
    if (pid == 0) { /* the child: the import alone, its crash a plain signal */
        signal(SIGSEGV, SIG_DFL);
        signal(SIGBUS, SIG_DFL);
        signal(SIGFPE, SIG_DFL);
        signal(SIGILL, SIG_DFL);
        signal(SIGABRT, SIG_DFL);
        const struct aiScene *ai = aiImportFile(path, import_flags(flags));
        _exit(ai ? 0 : 3);
    }
    int st = 0;
    while (waitpid(pid, &st, 0) < 0)
        ;
    if (WIFSIGNALED(st))
        return tnd_fail(TND_ERR_BAD_INPUT,
                        "scene: %s: malformed: the importer (assimp) crashed reading it (signal "
                        "%d)", path, WTERMSIG(st));
    if (WIFEXITED(st) && WEXITSTATUS(st) != 0 && WEXITSTATUS(st) != 3)
        return tnd_fail(TND_ERR_BAD_INPUT,
                        "scene: %s: malformed: the importer (assimp) failed reading it (exit %d)",
                        path, WEXITSTATUS(st));
    return TND_OK;
}

/* assimp's import of the file; refused when assimp fails or finds the scene incomplete
 * (without meshes, when `meshes`). */
static tnd_result ctx_import(gltf_ctx *c, unsigned flags, bool meshes)
{
    c->ai = aiImportFile(c->path, import_flags(flags));
    if (!c->ai)
        return tnd_fail(TND_ERR_BAD_INPUT, "scene: %s: cannot import: %s", c->path,
                        aiGetErrorString());
    if (!c->ai->mRootNode || (c->ai->mFlags & AI_SCENE_FLAGS_INCOMPLETE) ||
        (meshes && !c->ai->mNumMeshes))
        return tnd_fail(TND_ERR_BAD_INPUT, "scene: %s: incomplete scene (no nodes or meshes)",
                        c->path);
    return TND_OK;
}

/* ---- OBJ + MTL, and the other formats assimp reads ------------------------------------------ */
/* A new texture appended to the scene (rgba8 of w x h, owned by the scene); its index, or -1
 * (out of memory: *res says so). */
static int32_t add_texture(gltf_ctx *c, const char *name, uint8_t *rgba8, uint32_t w, uint32_t h,
                           bool srgb, tnd_result *res)
{
    tnd_scene *s = c->s;
    tnd_texture *nt = realloc(s->textures, (s->texture_count + 1) * sizeof *nt);
    if (!nt) {
        free(rgba8);
        *res = tnd_fail(TND_ERR_OUT_OF_MEMORY, "scene: out of memory");
        return -1;
    }
    s->textures = nt;
    tnd_texture *tx = &s->textures[s->texture_count];
    memset(tx, 0, sizeof *tx);
    put_name(tx->name, sizeof tx->name, name);
    tx->srgb = srgb;
    tx->width = w, tx->height = h;
    tx->rgba8 = rgba8;
    return (int32_t)s->texture_count++;
}

/* The base colour texture with the opacity map's coverage as its alpha (map_d; the opacity map
 * resampled to the base's size, nearest): the opacity map's alpha where it has one (a PNG with
 * alpha used as its own mask), else its red channel (a grey mask). base < 0: white. */
static int32_t merge_opacity(gltf_ctx *c, int32_t base, int32_t opacity, tnd_result *res)
{
    const tnd_texture *op = &c->s->textures[opacity];
    uint32_t w = base >= 0 ? c->s->textures[base].width : op->width;
    uint32_t h = base >= 0 ? c->s->textures[base].height : op->height;
    uint8_t *px = malloc((size_t)w * h * 4);
    if (!px) {
        *res = tnd_fail(TND_ERR_OUT_OF_MEMORY, "scene: out of memory");
        return -1;
    }
    bool has_alpha = false;
    for (size_t k = 0; k < (size_t)op->width * op->height && !has_alpha; k++)
        has_alpha = op->rgba8[4 * k + 3] != 255;
    char name[256];
    snprintf(name, sizeof name, "%.120s + opacity %.120s",
             base >= 0 ? c->s->textures[base].name : "white", op->name);
    for (uint32_t y = 0; y < h; y++)
        for (uint32_t x = 0; x < w; x++) {
            uint8_t *d = px + 4 * ((size_t)y * w + x);
            if (base >= 0)
                memcpy(d, c->s->textures[base].rgba8 + 4 * ((size_t)y * w + x), 3);
            else
                d[0] = d[1] = d[2] = 255;
            size_t ox = (size_t)x * op->width / w, oy = (size_t)y * op->height / h;
            const uint8_t *o = op->rgba8 + 4 * (oy * op->width + ox);
            d[3] = has_alpha ? o[3] : o[0];
        }
    return add_texture(c, name, px, w, h, true, res);
}

/* A height (bump) map as a tangent-space normal map: the slope is the height difference per
 * texel (heights 0 to 1, central differences, repeat) times `scale` (MTL's -bm, default 1);
 * x along the texture's u, y towards the image's top (the normal maps' convention). */
static int32_t bump_to_normal(gltf_ctx *c, int32_t height, float scale, tnd_result *res)
{
    const tnd_texture *t = &c->s->textures[height];
    uint32_t w = t->width, h = t->height;
    uint8_t *px = malloc((size_t)w * h * 4);
    if (!px) {
        *res = tnd_fail(TND_ERR_OUT_OF_MEMORY, "scene: out of memory");
        return -1;
    }
#define H_AT(x, y) (t->rgba8[4 * ((size_t)(y) * w + (x))] / 255.0f)
    for (uint32_t y = 0; y < h; y++)
        for (uint32_t x = 0; x < w; x++) {
            float dx = 0.5f * (H_AT((x + 1) % w, y) - H_AT((x + w - 1) % w, y));
            float drow = 0.5f * (H_AT(x, (y + 1) % h) - H_AT(x, (y + h - 1) % h));
            /* n = (-dh/du, -dh/dv, 1), v upwards: dh/dv = -dh/drow */
            float n[3] = {-scale * dx, scale * drow, 1.0f};
            float l = sqrtf(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
            uint8_t *d = px + 4 * ((size_t)y * w + x);
            for (int k = 0; k < 3; k++)
                d[k] = (uint8_t)lrintf(255.0f * (0.5f + 0.5f * n[k] / l));
            d[3] = 255;
        }
#undef H_AT
    char name[256];
    snprintf(name, sizeof name, "normals from height %.200s", t->name);
    return add_texture(c, name, px, w, h, false, res);
}

/* The MTL material model (and the other formats', which assimp reports with the same keys) as
 * metal-rough, by the rule docs/scenes.md states ("OBJ and MTL"). */
static tnd_result load_materials_assimp(gltf_ctx *c)
{
    const struct aiScene *ai = c->ai;
    tnd_scene *s = c->s;
    TND_TRY_RETURN(alloc_materials(c));
    tnd_result res = TND_OK;
    for (unsigned i = 0; i < ai->mNumMaterials; i++) {
        const struct aiMaterial *am = ai->mMaterials[i];
        tnd_material *m = &s->materials[i];
        float kd[4] = {0.8f, 0.8f, 0.8f, 1}, ks[4] = {0, 0, 0, 1}, ke[4] = {0, 0, 0, 1};
        float ns = 0, d = 1, tr = 0, ni = 1.5f, bm = 1;
        int illum = 2;
        unsigned n = 4;
        aiGetMaterialFloatArray(am, AI_MATKEY_COLOR_DIFFUSE, kd, &n);
        n = 4;
        aiGetMaterialFloatArray(am, AI_MATKEY_COLOR_SPECULAR, ks, &n);
        n = 4;
        aiGetMaterialFloatArray(am, AI_MATKEY_COLOR_EMISSIVE, ke, &n);
        n = 1;
        aiGetMaterialFloatArray(am, AI_MATKEY_SHININESS, &ns, &n);
        n = 1;
        aiGetMaterialFloatArray(am, AI_MATKEY_OPACITY, &d, &n);
        n = 1;
        bool have_tr = aiGetMaterialFloatArray(am, AI_MATKEY_TRANSPARENCYFACTOR, &tr, &n) ==
                       aiReturn_SUCCESS;
        n = 1;
        aiGetMaterialFloatArray(am, AI_MATKEY_REFRACTI, &ni, &n);
        n = 1;
        aiGetMaterialFloatArray(am, AI_MATKEY_BUMPSCALING, &bm, &n);
        n = 1;
        aiGetMaterialIntegerArray(am, AI_MATKEY_OBJ_ILLUM, &illum, &n);
        if (have_tr && d >= 1.0f && tr > 0.0f && tr <= 1.0f)
            d = 1.0f - tr; /* Tr is 1 - d */
        const float *vals[] = {kd, ks, ke, &ns, &d, &ni, &bm};
        const int counts[] = {3, 3, 3, 1, 1, 1, 1};
        bool finite = true;
        for (int a = 0; a < 7; a++)
            for (int k = 0; k < counts[a]; k++)
                finite &= isfinite(vals[a][k]);
        if (!finite)
            return tnd_fail(TND_ERR_BAD_INPUT, "scene: %s: material %u '%s': a non-finite value",
                            c->path, i, m->name);
        float kdmax = fmaxf(kd[0], fmaxf(kd[1], kd[2])), ksmax = fmaxf(ks[0], fmaxf(ks[1], ks[2]));
        /* a metal: no diffuse colour, a specular one */
        bool metal = kdmax < 0.01f && ksmax >= 0.1f;
        for (int k = 0; k < 3; k++)
            m->base_color[k] = fminf(fmaxf(metal ? ks[k] : kd[k], 0.0f), 1.0f);
        m->base_color[3] = 1.0f;
        m->metallic = metal ? 1.0f : 0.0f;
        /* Phong exponent to roughness: Beckmann alpha = sqrt(2 / (Ns + 2)), taken as GGX's alpha
         * = roughness^2 */
        m->roughness = powf(2.0f / (fmaxf(ns, 0.0f) + 2.0f), 0.25f);
        /* the dielectric's specular lobe (F0 = 0.04 x factor): as strong as Ks asks, up to the
         * usual 4%; Ks = 0 is pure Lambert */
        m->specular = fminf(fmaxf(ksmax, 0.0f) / 0.04f, 1.0f);
        for (int k = 0; k < 3; k++)
            m->emission[k] = fmaxf(ke[k], 0.0f);
        m->ior = ni >= 1.0f && ni <= 5.0f ? ni : 1.5f;
        /* illum 4, 6, 7, 9: refraction (glass); with d < 1, thin glass; otherwise d < 1 or an
         * opacity map cut the surface out */
        bool glass = (illum == 4 || illum == 6 || illum == 7 || illum == 9) && d < 1.0f;
        if (glass) {
            m->transmission = 1.0f;
            m->specular = 1.0f;
            m->roughness = 0.0f;
        }
        m->tex_base_color = load_texture(c, am, aiTextureType_DIFFUSE, 0, true, m->name, &res);
        if (res != TND_OK)
            return res;
        int32_t op = load_texture(c, am, aiTextureType_OPACITY, 0, false, m->name, &res);
        if (res != TND_OK)
            return res;
        if (!glass && (d < 1.0f || op >= 0)) {
            m->alpha_test = true;
            m->alpha_cutoff = 0.5f;
            m->base_color[3] = fminf(fmaxf(d, 0.0f), 1.0f);
            if (op >= 0) {
                m->tex_base_color = merge_opacity(c, m->tex_base_color, op, &res);
                if (res != TND_OK)
                    return res;
            }
        }
        m->tex_normal = load_texture(c, am, aiTextureType_NORMALS, 0, false, m->name, &res);
        if (res != TND_OK)
            return res;
        if (m->tex_normal < 0) {
            int32_t ht = load_texture(c, am, aiTextureType_HEIGHT, 0, false, m->name, &res);
            if (res != TND_OK)
                return res;
            if (ht >= 0) {
                m->tex_normal = bump_to_normal(c, ht, bm, &res);
                if (res != TND_OK)
                    return res;
            }
        }
        m->tex_emission = load_texture(c, am, aiTextureType_EMISSIVE, 0, true, m->name, &res);
        if (res != TND_OK)
            return res;
        if (m->tex_emission >= 0 && !(m->emission[0] > 0 || m->emission[1] > 0 ||
                                      m->emission[2] > 0))
            m->emission[0] = m->emission[1] = m->emission[2] = 1.0f; /* map_Ke alone */
        m->kind = scene_classify(m);
    }
    return TND_OK;
}

/* The statements of an OBJ's MTL files that Tandem does not use, each kind named once with its
 * first line (assimp parses the file; this only reads it to say what is ignored). */
static void warn_mtl(const char *obj_path, const char *dir)
{
    static const char *const used[] = {"newmtl", "Kd",   "Ks",       "Ke",       "Ns",
                                       "d",      "Tr",   "Ni",       "illum",    "map_Kd",
                                       "map_d",  "bump", "map_Bump", "map_bump", "norm",
                                       "map_Ke", "#"};
    void *text = NULL;
    size_t size = 0;
    if (tnd_file_read(obj_path, &text, &size) != TND_OK)
        return;
    const char *t = text, *end = t + size;
    while (t < end) {
        const char *eol = memchr(t, '\n', (size_t)(end - t));
        if (!eol)
            eol = end;
        while (t < eol && (*t == ' ' || *t == '\t'))
            t++;
        if (eol - t > 7 && strncmp(t, "mtllib", 6) == 0) {
            char mtl[1024], path[2048];
            size_t len = (size_t)(eol - t - 7) < sizeof mtl - 1 ? (size_t)(eol - t - 7)
                                                                  : sizeof mtl - 1;
            memcpy(mtl, t + 7, len);
            mtl[len] = '\0';
            while (len && (mtl[len - 1] == '\r' || mtl[len - 1] == ' '))
                mtl[--len] = '\0';
            snprintf(path, sizeof path, "%s%s", dir, mtl);
            void *mt = NULL;
            size_t ms = 0;
            if (tnd_file_read(path, &mt, &ms) == TND_OK) {
                char seen[64][24];
                int nseen = 0, line = 0;
                const char *a = mt, *ae = a + ms;
                while (a < ae) {
                    const char *ael = memchr(a, '\n', (size_t)(ae - a));
                    if (!ael)
                        ael = ae;
                    line++;
                    while (a < ael && (*a == ' ' || *a == '\t'))
                        a++;
                    char kw[24];
                    size_t k = 0;
                    while (a + k < ael && k < sizeof kw - 1 && a[k] != ' ' && a[k] != '\t' &&
                           a[k] != '\r')
                        kw[k] = a[k], k++;
                    kw[k] = '\0';
                    bool known = k == 0 || kw[0] == '#';
                    for (size_t u = 0; u < sizeof used / sizeof *used && !known; u++)
                        known = strcmp(kw, used[u]) == 0;
                    for (int sn = 0; sn < nseen && !known; sn++)
                        known = strcmp(kw, seen[sn]) == 0;
                    if (!known && nseen < 64) {
                        snprintf(seen[nseen++], sizeof seen[0], "%s", kw);
                        tnd_warn("scene", "%s:%d: MTL statement '%s' is not used (ignored)", path,
                                 line, kw);
                    }
                    a = ael + 1;
                }
                free(mt);
            }
        }
        t = eol + 1;
    }
    free(text);
}

tnd_result scene_load_assimp(const char *path, const tnd_scene_options *o, tnd_scene **out)
{
    tnd_result res = TND_OK;
    gltf_ctx c;
    TND_TRY_RETURN(ctx_begin(&c, path));
    FILE *probe = fopen(path, "rb");
    if (!probe) {
        res = tnd_fail(TND_ERR_IO, "scene: %s: cannot open", path);
        goto fail;
    }
    fclose(probe);
    const char *dot = strrchr(path, '.');
    if (dot && strcasecmp(dot, ".obj") == 0)
        warn_mtl(path, c.dir);
    TND_TRY(probe_import(path, aiProcess_JoinIdenticalVertices));
    TND_TRY(ctx_import(&c, aiProcess_JoinIdenticalVertices, true));
    if (c.ai->mNumCameras || c.ai->mNumLights || c.ai->mNumAnimations)
        tnd_warn("scene", "%s: its %u camera(s), %u light(s) and %u animation(s) are not imported "
                 "(glTF carries them)",
                 path, c.ai->mNumCameras, c.ai->mNumLights, c.ai->mNumAnimations);
    TND_TRY(load_meshes(&c));
    TND_TRY(load_materials_assimp(&c));
    uint32_t cap = 0;
    TND_TRY(add_node(&c, c.ai->mRootNode, -1, &cap));
    TND_TRY(scene_finish(c.s, o));
    *out = c.s;
    c.s = NULL;
fail:
    if (c.ai)
        aiReleaseImport(c.ai);
    tnd_scene_destroy(c.s);
    return res;
}

tnd_result scene_load_gltf(const char *path, const tnd_scene_options *o, tnd_scene **out)
{
    tnd_result res = TND_OK;
    gltf_ctx c;
    void *bytes = NULL;
    size_t size = 0;
    TND_TRY_RETURN(ctx_begin(&c, path));
    TND_TRY(tnd_file_read(path, &bytes, &size));
    TND_TRY(parse_json(&c, bytes, size));
    bool glb = size >= 12 && memcmp(bytes, "glTF", 4) == 0;
    c.glb = glb ? bytes : NULL;
    c.glb_size = glb ? size : 0;
    TND_TRY(validate_primitives(&c));
    TND_TRY(ctx_import(&c, 0, false));
    TND_TRY(load_meshes(&c));
    TND_TRY(load_materials(&c));
    uint32_t cap = 0;
    TND_TRY(add_node(&c, c.ai->mRootNode, -1, &cap));
    TND_TRY(load_cameras_lights(&c));
    TND_TRY(load_animation(&c));
    TND_TRY(scene_finish(c.s, o));
    *out = c.s;
    c.s = NULL;
fail:
    if (c.ai)
        aiReleaseImport(c.ai);
    buffers_free(&c);
    cJSON_Delete(c.json);
    free(bytes);
    tnd_scene_destroy(c.s);
    return res;
}
