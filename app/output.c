/* app/output.c: the image files every command writes: linear HDR EXR (RGB float) and a preview
 * PNG. */
#include "app/app.h"

#include <math.h>
#include <stb/stb_image_write.h>
#include <stdlib.h>

/* Preview PNG: exposure from the frame's log-average luminance (key 0.18), Reinhard, sRGB. Real
 * tone mapping is the composite stage's. */
tnd_result app_write_preview(const char *path, const float *rgb, uint32_t w, uint32_t h)
{
    size_t n = (size_t)w * h;
    double logsum = 0;
    for (size_t q = 0; q < n; q++) {
        double l = 0.2126 * rgb[3 * q] + 0.7152 * rgb[3 * q + 1] + 0.0722 * rgb[3 * q + 2];
        logsum += log(1e-4 + (isfinite(l) && l > 0 ? l : 0));
    }
    double exposure = 0.18 / exp(logsum / (double)n);
    uint8_t *px = malloc(n * 3);
    if (!px)
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "render: out of memory");
    for (size_t q = 0; q < n * 3; q++) {
        double v = rgb[q] * exposure;
        v = isfinite(v) && v > 0 ? v / (1.0 + v) : 0.0;
        v = v <= 0.0031308 ? 12.92 * v : 1.055 * pow(v, 1.0 / 2.4) - 0.055;
        px[q] = (uint8_t)fmin(255.0, floor(v * 255.0 + 0.5));
    }
    tnd_result res = app_write_png(path, px, w, h);
    free(px);
    return res;
}

tnd_result app_write_png(const char *path, const uint8_t *rgb8, uint32_t w, uint32_t h)
{
    char tmp[2200];
    snprintf(tmp, sizeof tmp, "%s.tmp", path);
    int ok = stbi_write_png(tmp, (int)w, (int)h, 3, rgb8, (int)w * 3);
    if (!ok || rename(tmp, path) != 0) {
        remove(tmp);
        return tnd_fail(TND_ERR_IO, "render: %s: cannot write", path);
    }
    return TND_OK;
}

tnd_result app_write_rgb_exr(const char *path, const float *rgb, uint32_t w, uint32_t h)
{
    const tnd_exr_channel_desc ch[3] = {{"R", TND_EXR_FLOAT, rgb, 3},
                                        {"G", TND_EXR_FLOAT, rgb + 1, 3},
                                        {"B", TND_EXR_FLOAT, rgb + 2, 3}};
    return tnd_exr_write(path, w, h, ch, 3, NULL, 0, TND_EXR_ZIP);
}

