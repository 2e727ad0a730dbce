/* core/exr.c: scanline OpenEXR files through the OpenEXRCore C API.
 *
 * Writing: exr_start_write (temporary file, renamed on success), one part, required attributes,
 * channels (the library stores them sorted by name), header, then per chunk: chunk info,
 * encoder, pointers re-aimed at the chunk's first line (the library does not advance them),
 * run. Reading mirrors it, matching decoder channels by name. HALF <-> FLOAT conversion is done
 * by the library both ways. Errors from the library go to the caller's message, not stderr.
 * DWAA/DWAB files (lossy; OpenEXRCore 3.1 cannot decode them) are read through the C interface
 * of the C++ library's RGBA reader.
 * Entry points: tnd_exr_write, tnd_exr_read, tnd_exr_close, tnd_exr_find, tnd_exr_attr_*. */
#include "core/core.h"

#include <ImfCRgbaFile.h>
#include <openexr.h>
#include <stddef.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* Library messages are collected here. The handler cannot ask the context for its user data:
 * the library calls it with the context's lock held (exr_get_user_data would deadlock), so the
 * calling thread's current message buffer is found through a thread-local pointer instead. */
typedef struct exr_msgs {
    char text[512];
} exr_msgs;

static _Thread_local exr_msgs *current_msgs;

static void on_exr_error(exr_const_context_t ctxt, exr_result_t code, const char *msg)
{
    (void)ctxt;
    exr_msgs *m = current_msgs;
    if (m && !m->text[0])
        snprintf(m->text, sizeof m->text, "%s (%s)", msg ? msg : "",
                 exr_get_error_code_as_string(code));
}

static tnd_result exr_fail(const char *path, const char *what, exr_result_t rv, const exr_msgs *m)
{
    return tnd_fail(TND_ERR_IO, "exr: %s: %s: %s", path, what,
                    m && m->text[0] ? m->text : exr_get_default_error_message(rv));
}

#define EXR_TRY(call, what)                                                                        \
    do {                                                                                           \
        exr_result_t rv_ = (call);                                                                 \
        if (rv_ != EXR_ERR_SUCCESS) {                                                              \
            res = exr_fail(path, what, rv_, &msgs);                                                \
            goto fail;                                                                             \
        }                                                                                          \
    } while (0)

static exr_pixel_type_t pixel_type(tnd_exr_type t)
{
    return t == TND_EXR_HALF   ? EXR_PIXEL_HALF
           : t == TND_EXR_UINT ? EXR_PIXEL_UINT
                               : EXR_PIXEL_FLOAT;
}

static exr_compression_t compression_type(tnd_exr_compression c)
{
    switch (c) {
    case TND_EXR_PIZ:
        return EXR_COMPRESSION_PIZ;
    case TND_EXR_NONE:
        return EXR_COMPRESSION_NONE;
    case TND_EXR_RLE:
        return EXR_COMPRESSION_RLE;
    case TND_EXR_ZIPS:
        return EXR_COMPRESSION_ZIPS;
    default:
        return EXR_COMPRESSION_ZIP;
    }
}

/* OpenEXRCore before 3.4.8 (Debian 12 has 3.1) corrupts a ZIP/ZIPS chunk whose zlib output is
 * exactly as long as the raw data: it stores the zlib bytes, and the reader, seeing a chunk of
 * the raw size, takes them as raw (openexr issue 2306). The writer detects such a chunk and
 * writes the whole file again uncompressed. */
static _Atomic uint32_t exr_fallbacks;

uint32_t tnd_exr_uncompressed_fallbacks(void)
{
    return exr_fallbacks;
}

static tnd_result exr_write_once(const char *path, uint32_t width, uint32_t height,
                                 const tnd_exr_channel_desc *channels, uint32_t channel_count,
                                 const tnd_exr_attr *attrs, uint32_t attr_count,
                                 tnd_exr_compression compression, bool *collided);

tnd_result tnd_exr_write(const char *path, uint32_t width, uint32_t height,
                         const tnd_exr_channel_desc *channels, uint32_t channel_count,
                         const tnd_exr_attr *attrs, uint32_t attr_count,
                         tnd_exr_compression compression)
{
    bool collided = false;
    tnd_result res = exr_write_once(path, width, height, channels, channel_count, attrs,
                                    attr_count, compression, &collided);
    if (res == TND_OK && collided) {
        exr_fallbacks++;
        res = exr_write_once(path, width, height, channels, channel_count, attrs, attr_count,
                             TND_EXR_NONE, &collided);
    }
    return res;
}

static tnd_result exr_write_once(const char *path, uint32_t width, uint32_t height,
                                 const tnd_exr_channel_desc *channels, uint32_t channel_count,
                                 const tnd_exr_attr *attrs, uint32_t attr_count,
                                 tnd_exr_compression compression, bool *collided)
{
    tnd_result res = TND_OK;
    exr_msgs msgs = {{0}};
    exr_context_t ctx = NULL;
    exr_encode_pipeline_t enc;
    bool enc_init = false;
    if (width == 0 || height == 0 || width > 65536 || height > 65536 || channel_count == 0)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "exr: %s: bad image %ux%u with %u channels", path,
                        width, height, channel_count);
    /* Written under a temporary name and renamed on success: never a partial file at `path`. */
    char tmp[1100];
    if (snprintf(tmp, sizeof tmp, "%s.tmp.%ld", path, (long)getpid()) >= (int)sizeof tmp)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "exr: %s: path too long", path);
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = on_exr_error;
    current_msgs = &msgs;
    EXR_TRY(exr_start_write(&ctx, tmp, EXR_WRITE_FILE_DIRECTLY, &init), "cannot create");
    int part;
    EXR_TRY(exr_add_part(ctx, "tandem", EXR_STORAGE_SCANLINE, &part), "add part");
    EXR_TRY(exr_initialize_required_attr_simple(ctx, part, (int32_t)width, (int32_t)height,
                                                compression_type(compression)),
            "header");
    for (uint32_t c = 0; c < channel_count; c++)
        EXR_TRY(exr_add_channel(ctx, part, channels[c].name, pixel_type(channels[c].type),
                                EXR_PERCEPTUALLY_LINEAR, 1, 1),
                "add channel");
    for (uint32_t a = 0; a < attr_count; a++) {
        const tnd_exr_attr *at = &attrs[a];
        switch (at->type) {
        case TND_ATTR_INT:
            EXR_TRY(exr_attr_set_int(ctx, part, at->name, at->i), "attribute");
            break;
        case TND_ATTR_FLOAT:
            EXR_TRY(exr_attr_set_float(ctx, part, at->name, at->f[0]), "attribute");
            break;
        case TND_ATTR_V2F: {
            exr_attr_v2f_t v = {.x = at->f[0], .y = at->f[1]};
            EXR_TRY(exr_attr_set_v2f(ctx, part, at->name, &v), "attribute");
            break;
        }
        case TND_ATTR_M44F: {
            exr_attr_m44f_t m;
            memcpy(m.m, at->f, sizeof m.m);
            EXR_TRY(exr_attr_set_m44f(ctx, part, at->name, &m), "attribute");
            break;
        }
        case TND_ATTR_STRING:
            EXR_TRY(exr_attr_set_string(ctx, part, at->name, at->s ? at->s : ""), "attribute");
            break;
        }
    }
    EXR_TRY(exr_write_header(ctx), "write header");

    int32_t lines = 0;
    EXR_TRY(exr_get_scanlines_per_chunk(ctx, part, &lines), "chunk size");
    int32_t nchunks = ((int32_t)height + lines - 1) / lines;
    for (int32_t k = 0; k < nchunks; k++) {
        int32_t y0 = k * lines;
        exr_chunk_info_t ci;
        EXR_TRY(exr_write_scanline_chunk_info(ctx, part, y0, &ci), "chunk info");
        if (!enc_init) {
            EXR_TRY(exr_encoding_initialize(ctx, part, &ci, &enc), "encoder");
            enc_init = true;
        } else {
            EXR_TRY(exr_encoding_update(ctx, part, &ci, &enc), "encoder");
        }
        for (int16_t c = 0; c < enc.channel_count; c++) {
            exr_coding_channel_info_t *ch = &enc.channels[c];
            const tnd_exr_channel_desc *src = NULL;
            for (uint32_t s = 0; s < channel_count && !src; s++)
                if (strcmp(channels[s].name, ch->channel_name) == 0)
                    src = &channels[s];
            uint32_t stride = src->stride ? src->stride : 1;
            ch->user_bytes_per_element = 4;
            ch->user_data_type = src->type == TND_EXR_UINT ? EXR_PIXEL_UINT : EXR_PIXEL_FLOAT;
            ch->user_pixel_stride = (int32_t)(4 * stride);
            ch->user_line_stride = (int32_t)(4 * stride * width);
            ch->encode_from_ptr =
                (const uint8_t *)src->data + (size_t)4 * stride * width * (size_t)y0;
        }
        if (k == 0)
            EXR_TRY(exr_encoding_choose_default_routines(ctx, part, &enc), "encoder");
        EXR_TRY(exr_encoding_run(ctx, part, &enc), "encode");
        if ((compression == TND_EXR_ZIP || compression == TND_EXR_ZIPS) &&
            enc.compressed_bytes == enc.packed_bytes && enc.packed_bytes > 0 &&
            enc.compressed_buffer != enc.packed_buffer &&
            memcmp(enc.compressed_buffer, enc.packed_buffer, enc.packed_bytes) != 0)
            *collided = true; /* zlib bytes of the raw size: unreadable (see above) */
    }
fail:
    if (enc_init)
        exr_encoding_destroy(ctx, &enc);
    if (ctx) {
        exr_result_t rv = exr_finish(&ctx);
        if (res == TND_OK && rv != EXR_ERR_SUCCESS)
            res = exr_fail(path, "finish", rv, &msgs);
        if (res == TND_OK && rename(tmp, path) != 0)
            res = tnd_fail(TND_ERR_IO, "exr: %s: cannot rename into place", path);
        if (res != TND_OK)
            remove(tmp);
    }
    current_msgs = NULL;
    return res;
}

void tnd_exr_close(tnd_exr_file *f)
{
    for (uint32_t c = 0; f->channels && c < f->channel_count; c++)
        free(f->channels[c].data);
    free(f->channels);
    if (f->ctx) {
        exr_context_t ctx = f->ctx;
        exr_finish(&ctx);
    }
    memset(f, 0, sizeof *f);
}

/* The bytes the C++ reader consumes for an attribute of a fixed-size type (0: not one). It
 * reads that many whatever the attribute declares, so a declared size that differs loses its
 * place in the header: a float "dwaCompressionLevel" declaring 1074 bytes led it to read a
 * string of 1.85 GB from the bytes after (found by tests/fuzz/fuzz_env). */
static int fixed_attribute_size(const char *type)
{
    static const struct {
        const char *type;
        int bytes;
    } fixed[] = {{"box2i", 16},   {"box2f", 16},         {"chromaticities", 32},
                 {"compression", 1}, {"double", 8},      {"envmap", 1},
                 {"float", 4},    {"int", 4},            {"keycode", 28},
                 {"lineOrder", 1}, {"m33f", 36},         {"m33d", 72},
                 {"m44f", 64},    {"m44d", 128},         {"rational", 8},
                 {"tiledesc", 9}, {"timecode", 8},       {"v2i", 8},
                 {"v2f", 8},      {"v2d", 16},           {"v3i", 12},
                 {"v3f", 12},     {"v3d", 24},           {"deepImageState", 1}};
    for (size_t i = 0; i < sizeof fixed / sizeof *fixed; i++)
        if (strcmp(type, fixed[i].type) == 0)
            return fixed[i].bytes;
    return 0;
}

static uint32_t le32(const uint8_t *b)
{
    return (uint32_t)b[0] | (uint32_t)b[1] << 8 | (uint32_t)b[2] << 16 | (uint32_t)b[3] << 24;
}

/* Whether the value of a variable-size attribute (`v`, `size` bytes) ends where the C++ reader
 * would stop reading it: a channel list at its empty name, a preview after its width x height
 * RGBA bytes, each string of a string vector within the value. Other types it reads as
 * declared. */
static bool variable_attribute_fits(const char *type, const uint8_t *v, int64_t size)
{
    if (strcmp(type, "chlist") == 0) {
        int64_t at = 0;
        for (;;) { /* name, then pixel type, pLinear and 3 reserved bytes, x and y sampling */
            int64_t len = 0;
            while (at + len < size && v[at + len] != 0)
                len++;
            if (at + len >= size)
                return false;
            if (len == 0)
                return at + 1 == size;
            at += len + 1 + 16;
            if (at > size)
                return false;
        }
    }
    if (strcmp(type, "preview") == 0) { /* (w x h x 4 compared without overflowing) */
        uint64_t w = size >= 8 ? le32(v) : 0, h = size >= 8 ? le32(v + 4) : 0;
        return size >= 8 && (w == 0 || h <= (uint64_t)(size - 8) / 4 / w) &&
               w * h * 4 == (uint64_t)(size - 8);
    }
    if (strcmp(type, "stringvector") == 0) {
        for (int64_t at = 0; at < size;) {
            if (size - at < 4)
                return false;
            int64_t len = (int32_t)le32(v + at);
            at += 4;
            if (len < 0 || len > size - at)
                return false;
            at += len;
        }
    }
    return true;
}

/* Every attribute of the (single-part) header fits in the file, and is read by OpenEXR 3.1's C++
 * reader as it declares itself. That reader trusts a declared size and allocates it before
 * reading (a 3 KB file whose "Software" string says 1.9 GB took 2 GB: found by
 * tests/fuzz/fuzz_env); OpenEXRCore had read the same header. */
static tnd_result check_header_sizes(const char *path)
{
    FILE *fp = fopen(path, "rb");
    if (!fp)
        return tnd_fail(TND_ERR_IO, "exr: %s: cannot open", path);
    tnd_result res = TND_OK;
    long file_size = fseek(fp, 0, SEEK_END) == 0 ? ftell(fp) : -1;
    uint8_t v[8];
    if (file_size < 8 || fseek(fp, 0, SEEK_SET) != 0 || fread(v, 1, 8, fp) != 8) {
        res = tnd_fail(TND_ERR_BAD_INPUT, "exr: %s: shorter than a header", path);
        goto done;
    }
    /* names and type names: at most 31 bytes unless the version sets the long-names flag (the
     * C++ reader reads 32 bytes of a longer name and loses its place: a 3 KB file's text then
     * declared a 1.9 GB string) */
    int max_name = (v[5] & 0x04) ? 255 : 31; /* (flag 0x400 of the version word) */
    for (int attr = 0;; attr++) {
        char name[2][256];
        for (int part = 0; part < 2; part++) { /* the attribute's name, then its type */
            int len = 0, ch;
            while ((ch = fgetc(fp)) > 0 && len < max_name)
                name[part][len++] = (char)ch;
            name[part][len] = 0;
            if (ch < 0 || (ch > 0 && len == max_name)) {
                res = tnd_fail(TND_ERR_BAD_INPUT, "exr: %s: header attribute %d: a name of "
                               "more than %d bytes (the version's long-names flag is %s) or the "
                               "file ends", path, attr, max_name, max_name == 255 ? "set" : "not set");
                goto done;
            }
            if (part == 0 && len == 0) /* the header's end */
                goto done;
        }
        uint8_t b[4];
        if (fread(b, 1, 4, fp) != 4) {
            res = tnd_fail(TND_ERR_BAD_INPUT, "exr: %s: header attribute '%s': the file ends",
                           path, name[0]);
            goto done;
        }
        int64_t size = (int32_t)((uint32_t)b[0] | (uint32_t)b[1] << 8 | (uint32_t)b[2] << 16 |
                                 (uint32_t)b[3] << 24);
        long at = ftell(fp);
        if (size < 0 || at < 0 || size > (int64_t)file_size - at) {
            res = tnd_fail(TND_ERR_BAD_INPUT,
                           "exr: %s: header attribute '%s' (%s) declares %lld bytes, more than "
                           "the file holds", path, name[0], name[1], (long long)size);
            goto done;
        }
        int fixed = fixed_attribute_size(name[1]);
        if (fixed && size != fixed) {
            res = tnd_fail(TND_ERR_BAD_INPUT,
                           "exr: %s: header attribute '%s' (%s) declares %lld bytes; the type "
                           "has %d", path, name[0], name[1], (long long)size, fixed);
            goto done;
        }
        if (!fixed) { /* the value itself, where its reader stops on what it holds */
            uint8_t *value = malloc(size ? (size_t)size : 1);
            if (!value) {
                res = tnd_fail(TND_ERR_OUT_OF_MEMORY, "exr: %s: out of memory", path);
                goto done;
            }
            bool ok = fread(value, 1, (size_t)size, fp) == (size_t)size &&
                      variable_attribute_fits(name[1], value, size);
            free(value);
            if (!ok) {
                res = tnd_fail(TND_ERR_BAD_INPUT,
                               "exr: %s: header attribute '%s' (%s): its %lld bytes do not hold "
                               "one value of its type", path, name[0], name[1], (long long)size);
                goto done;
            }
        } else if (fseek(fp, (long)size, SEEK_CUR) != 0) {
            res = tnd_fail(TND_ERR_IO, "exr: %s: cannot seek", path);
            goto done;
        }
    }
done:
    fclose(fp);
    return res;
}

/* DWAA/DWAB, which OpenEXRCore 3.1 cannot decode (HDRIs come so: Blender's, HDRI Haven's): the
 * C interface of the C++ library's RGBA reader, for R, G, B and A (any other channel is
 * refused by name). It delivers half values; DWA is lossy and stores half precision anyway. */
static tnd_result read_rgba_imf(tnd_exr_file *f, int x0, int y0, const char *codec)
{
    static const char names[4][2] = {"R", "G", "B", "A"};
    tnd_exr_channel *dst[4] = {NULL, NULL, NULL, NULL};
    for (uint32_t c = 0; c < f->channel_count; c++) {
        int k = 0;
        while (k < 4 && strcmp(f->channels[c].name, names[k]) != 0)
            k++;
        if (k == 4 || f->channels[c].type == TND_EXR_UINT)
            return tnd_fail(TND_ERR_UNSUPPORTED,
                            "exr: %s: %s compression is read for half or float R, G, B, A "
                            "channels only (channel '%s')",
                            f->path, codec, f->channels[c].name);
        dst[k] = &f->channels[c];
    }
    TND_TRY_RETURN(check_header_sizes(f->path));
    size_t w = f->width, h = f->height;
    ImfRgba *px = malloc(w * h * sizeof *px);
    if (!px)
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "exr: %s: out of memory", f->path);
    ImfInputFile *in = ImfOpenInputFile(f->path);
    if (!in) {
        free(px);
        return tnd_fail(TND_ERR_IO, "exr: %s: %s", f->path, ImfErrorMessage());
    }
    /* the frame buffer is addressed by absolute pixel coordinates */
    ptrdiff_t origin = -(ptrdiff_t)x0 - (ptrdiff_t)y0 * (ptrdiff_t)w;
    bool ok = ImfInputSetFrameBuffer(in, px + origin, 1, w) &&
              ImfInputReadPixels(in, y0, y0 + (int)h - 1);
    tnd_result res = TND_OK;
    if (!ok)
        res = tnd_fail(TND_ERR_BAD_INPUT, "exr: %s: decode (%s): %s", f->path, codec,
                       ImfErrorMessage());
    ImfCloseInputFile(in);
    for (int k = 0; k < 4 && res == TND_OK; k++)
        if (dst[k] && dst[k]->data)
            for (size_t i = 0; i < w * h; i++) {
                ImfHalf v = k == 0 ? px[i].r : k == 1 ? px[i].g : k == 2 ? px[i].b : px[i].a;
                ((float *)dst[k]->data)[i] = ImfHalfToFloat(v);
            }
    free(px);
    return res;
}

tnd_result tnd_exr_read(const char *path, tnd_exr_file *f)
{
    tnd_result res = TND_OK;
    exr_msgs msgs = {{0}};
    exr_context_t ctx = NULL;
    exr_decode_pipeline_t dec;
    bool dec_init = false;
    memset(f, 0, sizeof *f);
    snprintf(f->path, sizeof f->path, "%s", path);
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = on_exr_error;
    current_msgs = &msgs;
    init.flags = EXR_CONTEXT_FLAG_SILENT_HEADER_PARSE;
    EXR_TRY(exr_start_read(&ctx, path, &init), "cannot read as OpenEXR");
    f->ctx = ctx;
    int parts = 0;
    EXR_TRY(exr_get_count(ctx, &parts), "parts");
    exr_storage_t storage;
    EXR_TRY(exr_get_storage(ctx, 0, &storage), "storage");
    if (storage != EXR_STORAGE_SCANLINE) {
        res = tnd_fail(TND_ERR_UNSUPPORTED, "exr: %s: only scanline images are supported", path);
        goto fail;
    }
    exr_attr_box2i_t dw;
    EXR_TRY(exr_get_data_window(ctx, 0, &dw), "data window");
    int64_t w = (int64_t)dw.max.x - dw.min.x + 1, h = (int64_t)dw.max.y - dw.min.y + 1;
    if (w <= 0 || h <= 0 || w > 65536 || h > 65536) {
        res = tnd_fail(TND_ERR_BAD_INPUT, "exr: %s: data window %lldx%lld", path, (long long)w,
                       (long long)h);
        goto fail;
    }
    f->width = (uint32_t)w;
    f->height = (uint32_t)h;
    const exr_attr_chlist_t *chl = NULL;
    EXR_TRY(exr_get_channels(ctx, 0, &chl), "channels");
    f->channel_count = (uint32_t)chl->num_channels;
    /* What the pixels take once read (4 bytes a channel) against what the file holds: no
     * compression OpenEXR has packs more than some thousand to one, and a header may declare
     * any size (a 1.8 KB file declaring 1.6 billion pixels asked for 6.6 GB: found by
     * tests/fuzz/fuzz_env). 256 MiB are allowed whatever the file's size. */
    FILE *fp = fopen(path, "rb");
    long file_size = fp && fseek(fp, 0, SEEK_END) == 0 ? ftell(fp) : -1;
    if (fp)
        fclose(fp);
    double need = (double)w * (double)h * 4.0 * (double)chl->num_channels;
    double allowed = fmax(256.0 * 1048576.0, 2048.0 * (double)(file_size > 0 ? file_size : 0));
    if (need > allowed) {
        res = tnd_fail(TND_ERR_BAD_INPUT,
                       "exr: %s: declares %lldx%lld pixels of %d channels (%.0f MB) in a file of "
                       "%ld bytes: more than any compression packs", path, (long long)w,
                       (long long)h, chl->num_channels, need / 1048576.0, file_size);
        goto fail;
    }
    f->channels = calloc(f->channel_count ? f->channel_count : 1, sizeof *f->channels);
    if (!f->channels) {
        res = tnd_fail(TND_ERR_OUT_OF_MEMORY, "exr: %s: out of memory", path);
        goto fail;
    }
    for (uint32_t c = 0; c < f->channel_count; c++) {
        const exr_attr_chlist_entry_t *e = &chl->entries[c];
        tnd_exr_channel *ch = &f->channels[c];
        snprintf(ch->name, sizeof ch->name, "%s", e->name.str);
        ch->type = e->pixel_type == EXR_PIXEL_HALF   ? TND_EXR_HALF
                   : e->pixel_type == EXR_PIXEL_UINT ? TND_EXR_UINT
                                                     : TND_EXR_FLOAT;
        ch->x_sampling = e->x_sampling;
        ch->y_sampling = e->y_sampling;
        /* (OpenEXRCore 3.1 decodes into a null pointer when a subsampled channel is skipped:
         * a 1x4 channel in an uncompressed file crashed it, found by tests/fuzz/fuzz_env) */
        if (e->x_sampling != 1 || e->y_sampling != 1) {
            res = tnd_fail(TND_ERR_UNSUPPORTED,
                           "exr: %s: channel '%s' is subsampled (%dx%d): Tandem reads "
                           "full-resolution channels only", path, ch->name, e->x_sampling,
                           e->y_sampling);
            goto fail;
        }
        ch->data = calloc((size_t)w * (size_t)h, 4);
        if (!ch->data) {
            res = tnd_fail(TND_ERR_OUT_OF_MEMORY, "exr: %s: out of memory", path);
            goto fail;
        }
    }
    exr_compression_t comp;
    EXR_TRY(exr_get_compression(ctx, 0, &comp), "compression");
    if (comp == EXR_COMPRESSION_DWAA || comp == EXR_COMPRESSION_DWAB) {
        TND_TRY(read_rgba_imf(f, dw.min.x, dw.min.y,
                              comp == EXR_COMPRESSION_DWAA ? "DWAA" : "DWAB"));
        current_msgs = NULL;
        return TND_OK;
    }
    int32_t lines = 0;
    EXR_TRY(exr_get_scanlines_per_chunk(ctx, 0, &lines), "chunk size");
    for (int64_t y = dw.min.y; y <= dw.max.y; y += lines) {
        exr_chunk_info_t ci;
        EXR_TRY(exr_read_scanline_chunk_info(ctx, 0, (int)y, &ci), "chunk table");
        if (!dec_init) {
            EXR_TRY(exr_decoding_initialize(ctx, 0, &ci, &dec), "decoder");
            dec_init = true;
        } else {
            EXR_TRY(exr_decoding_update(ctx, 0, &ci, &dec), "decoder");
        }
        for (int16_t c = 0; c < dec.channel_count; c++) {
            exr_coding_channel_info_t *dc = &dec.channels[c];
            tnd_exr_channel *ch = NULL;
            for (uint32_t s = 0; s < f->channel_count && !ch; s++)
                if (strcmp(f->channels[s].name, dc->channel_name) == 0)
                    ch = &f->channels[s];
            if (!ch || !ch->data) {
                dc->decode_to_ptr = NULL; /* skipped */
                continue;
            }
            dc->user_bytes_per_element = 4;
            dc->user_data_type = ch->type == TND_EXR_UINT ? EXR_PIXEL_UINT : EXR_PIXEL_FLOAT;
            dc->user_pixel_stride = 4;
            dc->user_line_stride = (int32_t)(4 * w);
            dc->decode_to_ptr =
                (uint8_t *)ch->data + (size_t)4 * w * (size_t)(ci.start_y - dw.min.y);
        }
        if (y == dw.min.y)
            EXR_TRY(exr_decoding_choose_default_routines(ctx, 0, &dec), "decoder");
        EXR_TRY(exr_decoding_run(ctx, 0, &dec), "decode (truncated or corrupt file?)");
    }
    if (dec_init)
        exr_decoding_destroy(ctx, &dec);
    current_msgs = NULL;
    return TND_OK;
fail:
    if (dec_init)
        exr_decoding_destroy(ctx, &dec);
    if (!f->ctx && ctx)
        exr_finish(&ctx);
    tnd_exr_close(f);
    current_msgs = NULL;
    return res;
}

const tnd_exr_channel *tnd_exr_find(const tnd_exr_file *f, const char *name)
{
    for (uint32_t c = 0; c < f->channel_count; c++)
        if (strcmp(f->channels[c].name, name) == 0)
            return &f->channels[c];
    return NULL;
}

static const exr_attribute_t *find_attr(const tnd_exr_file *f, const char *name,
                                        exr_attribute_type_t type)
{
    const exr_attribute_t *a = NULL;
    if (!f->ctx || exr_get_attribute_by_name(f->ctx, 0, name, &a) != EXR_ERR_SUCCESS || !a ||
        a->type != type)
        return NULL;
    return a;
}

bool tnd_exr_attr_int(const tnd_exr_file *f, const char *name, int32_t *v)
{
    const exr_attribute_t *a = find_attr(f, name, EXR_ATTR_INT);
    if (a)
        *v = a->i;
    return a != NULL;
}

bool tnd_exr_attr_v2f(const tnd_exr_file *f, const char *name, float v[2])
{
    const exr_attribute_t *a = find_attr(f, name, EXR_ATTR_V2F);
    if (a) {
        v[0] = a->v2f->x;
        v[1] = a->v2f->y;
    }
    return a != NULL;
}

bool tnd_exr_attr_m44f(const tnd_exr_file *f, const char *name, float m[16])
{
    const exr_attribute_t *a = find_attr(f, name, EXR_ATTR_M44F);
    if (a)
        memcpy(m, a->m44f->m, 16 * sizeof(float));
    return a != NULL;
}

bool tnd_exr_attr_string(const tnd_exr_file *f, const char *name, char *out, size_t cap)
{
    const exr_attribute_t *a = find_attr(f, name, EXR_ATTR_STRING);
    if (a)
        snprintf(out, cap, "%.*s", a->string->length, a->string->str);
    return a != NULL;
}
