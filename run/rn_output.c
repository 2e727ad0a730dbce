/* run/rn_output.c: the files every command writes: linear HDR EXR (RGB float), a preview PNG, the
 * MP4 of a run's PNGs (ffmpeg), and JSON documents. */
#include "run/rn_internal.h"

#include <cjson/cJSON.h>
#include <errno.h>
#include <math.h>
#include <stb/stb_image_write.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <unistd.h>

/* Preview PNG: exposure from the frame's log-average luminance (key 0.18), Reinhard, sRGB. Real
 * tone mapping is the composite stage's. */
tnd_result rn_write_preview(const char *path, const float *rgb, uint32_t w, uint32_t h)
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
    tnd_result res = rn_write_png(path, px, w, h);
    free(px);
    return res;
}

tnd_result rn_write_png(const char *path, const uint8_t *rgb8, uint32_t w, uint32_t h)
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

tnd_result rn_write_rgb_exr(const char *path, const float *rgb, uint32_t w, uint32_t h)
{
    const tnd_exr_channel_desc ch[3] = {{"R", TND_EXR_FLOAT, rgb, 3},
                                        {"G", TND_EXR_FLOAT, rgb + 1, 3},
                                        {"B", TND_EXR_FLOAT, rgb + 2, 3}};
    return tnd_exr_write(path, w, h, ch, 3, NULL, 0, TND_EXR_ZIP);
}


/* Is `prog` an executable on PATH? */
bool rn_have_program(const char *prog)
{
    const char *path = getenv("PATH");
    char buf[4096];
    while (path && *path) {
        const char *end = strchr(path, ':');
        size_t n = end ? (size_t)(end - path) : strlen(path);
        if (n > 0 && n + strlen(prog) + 2 < sizeof buf) {
            memcpy(buf, path, n);
            snprintf(buf + n, sizeof buf - n, "/%s", prog);
            if (access(buf, X_OK) == 0)
                return true;
        }
        path = end ? end + 1 : NULL;
    }
    return false;
}

/* DIR/video.mp4 from DIR/frame_NNNN.png (first, first+1, ...) with ffmpeg: H.264, yuv420p (what
 * players expect; odd sizes padded by one black row or column), constant quality CRF 18. Written
 * under a temporary name and renamed, so a failed encode leaves no file. */
tnd_result rn_write_video(const char *dir, unsigned first, unsigned count, double fps)
{
    char pattern[2100], out[2100], tmp[2200], rate[32], start[32], frames[32];
    snprintf(pattern, sizeof pattern, "%s/frame_%%04d.png", dir);
    snprintf(out, sizeof out, "%s/video.mp4", dir);
    snprintf(tmp, sizeof tmp, "%s/video.mp4.tmp", dir);
    snprintf(rate, sizeof rate, "%.6g", fps);
    snprintf(start, sizeof start, "%u", first);
    snprintf(frames, sizeof frames, "%u", count);
    char *const argv[] = {"ffmpeg", "-nostdin", "-y", "-loglevel", "error", "-framerate", rate,
                          "-start_number", start, "-i", pattern, "-frames:v", frames,
                          "-vf", "pad=ceil(iw/2)*2:ceil(ih/2)*2", "-c:v", "libx264",
                          "-pix_fmt", "yuv420p", "-crf", "18", "-f", "mp4", tmp, NULL};
    fflush(NULL);
    pid_t pid = fork();
    if (pid < 0)
        return tnd_fail(TND_ERR_IO, "render: --video: cannot start ffmpeg");
    if (pid == 0) {
        execvp("ffmpeg", argv);
        _exit(127);
    }
    int status = 0;
    while (waitpid(pid, &status, 0) < 0)
        if (errno != EINTR) {
            status = -1;
            break;
        }
    if (status != 0 || rename(tmp, out) != 0) {
        remove(tmp);
        return tnd_fail(TND_ERR_IO, "render: --video: ffmpeg could not encode %s (exit status %d)",
                        out, WIFEXITED(status) ? WEXITSTATUS(status) : -1);
    }
    return TND_OK;
}

tnd_result rn_json_write(const char *path, const void *json)
{
    char *txt = cJSON_Print(json);
    size_t n = txt ? strlen(txt) : 0;
    char *all = txt ? realloc(txt, n + 2) : NULL;
    if (!all) {
        free(txt);
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "%s: out of memory", path);
    }
    all[n] = '\n', all[n + 1] = '\0';
    tnd_result res = tnd_file_write_atomic(path, all, n + 1);
    free(all);
    return res;
}
