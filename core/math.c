/* core/math.c: the little linear algebra Tandem needs on the CPU: 4x4 matrices (column-major,
 * as GLSL), glTF TRS composition, a Vulkan perspective, quaternion slerp, camera rays; and a
 * progressive reference's statistics (tnd_ref_finish, tnd_ref_run). */
#include "core/core.h"
#include "shaders/brdf.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

void tnd_mat4_identity(float m[16])
{
    memset(m, 0, 16 * sizeof *m);
    m[0] = m[5] = m[10] = m[15] = 1.0f;
}

void tnd_mat4_mul(const float a[16], const float b[16], float out[16])
{
    float r[16];
    for (int c = 0; c < 4; c++)
        for (int row = 0; row < 4; row++) {
            double s = 0;
            for (int k = 0; k < 4; k++)
                s += (double)a[k * 4 + row] * b[c * 4 + k];
            r[c * 4 + row] = (float)s;
        }
    memcpy(out, r, sizeof r);
}

bool tnd_mat4_inverse(const float m[16], float out[16])
{
    /* Gauss-Jordan with partial pivoting in double. */
    double a[4][8];
    for (int r = 0; r < 4; r++)
        for (int c = 0; c < 4; c++) {
            a[r][c] = m[c * 4 + r];
            a[r][c + 4] = r == c;
        }
    for (int c = 0; c < 4; c++) {
        int p = c;
        for (int r = c + 1; r < 4; r++)
            if (fabs(a[r][c]) > fabs(a[p][c]))
                p = r;
        if (fabs(a[p][c]) < 1e-300) {
            tnd_mat4_identity(out);
            return false;
        }
        if (p != c)
            for (int k = 0; k < 8; k++) {
                double t = a[c][k];
                a[c][k] = a[p][k];
                a[p][k] = t;
            }
        double inv = 1.0 / a[c][c];
        for (int k = 0; k < 8; k++)
            a[c][k] *= inv;
        for (int r = 0; r < 4; r++) {
            if (r == c)
                continue;
            double f = a[r][c];
            for (int k = 0; k < 8; k++)
                a[r][k] -= f * a[c][k];
        }
    }
    for (int r = 0; r < 4; r++)
        for (int c = 0; c < 4; c++)
            out[c * 4 + r] = (float)a[r][c + 4];
    return true;
}

void tnd_mat4_point(const float m[16], const float p[3], bool project, float out[3])
{
    double v[4];
    for (int r = 0; r < 4; r++)
        v[r] = (double)m[r] * p[0] + (double)m[4 + r] * p[1] + (double)m[8 + r] * p[2] + m[12 + r];
    double w = project && v[3] != 0.0 ? v[3] : 1.0;
    for (int r = 0; r < 3; r++)
        out[r] = (float)(v[r] / w);
}

void tnd_mat4_dir(const float m[16], const float d[3], float out[3])
{
    float r[3];
    for (int i = 0; i < 3; i++)
        r[i] = m[i] * d[0] + m[4 + i] * d[1] + m[8 + i] * d[2];
    memcpy(out, r, sizeof r);
}

void tnd_mat4_trs(const float t[3], const float q[4], const float s[3], float out[16])
{
    double x = q[0], y = q[1], z = q[2], w = q[3];
    double n = sqrt(x * x + y * y + z * z + w * w);
    if (n > 0) {
        x /= n, y /= n, z /= n, w /= n;
    } else {
        x = y = z = 0, w = 1;
    }
    double r[9] = {1 - 2 * (y * y + z * z), 2 * (x * y + z * w),     2 * (x * z - y * w),
                   2 * (x * y - z * w),     1 - 2 * (x * x + z * z), 2 * (y * z + x * w),
                   2 * (x * z + y * w),     2 * (y * z - x * w),     1 - 2 * (x * x + y * y)};
    for (int c = 0; c < 3; c++) {
        for (int row = 0; row < 3; row++)
            out[c * 4 + row] = (float)(r[c * 3 + row] * s[c]);
        out[c * 4 + 3] = 0.0f;
    }
    out[12] = t[0], out[13] = t[1], out[14] = t[2], out[15] = 1.0f;
}

void tnd_mat4_perspective(float yfov, float aspect, float znear, float zfar, float out[16])
{
    double f = 1.0 / tan(0.5 * yfov);
    memset(out, 0, 16 * sizeof *out);
    out[0] = (float)(f / aspect);
    out[5] = (float)-f; /* Vulkan clip space: y down */
    out[11] = -1.0f;
    if (zfar > 0.0f) {
        out[10] = zfar / (znear - zfar);
        out[14] = znear * zfar / (znear - zfar);
    } else {
        out[10] = -1.0f;
        out[14] = -znear;
    }
}

void tnd_quat_slerp(const float a[4], const float b[4], float t, float out[4])
{
    double d =
        (double)a[0] * b[0] + (double)a[1] * b[1] + (double)a[2] * b[2] + (double)a[3] * b[3];
    double sb = 1.0;
    if (d < 0) {
        d = -d;
        sb = -1.0;
    }
    double wa, wb;
    if (d > 0.9995) { /* nearly parallel: normalised lerp */
        wa = 1.0 - t;
        wb = t * sb;
    } else {
        double th = acos(d), s = sin(th);
        wa = sin((1.0 - t) * th) / s;
        wb = sin(t * th) / s * sb;
    }
    double r[4], n = 0;
    for (int i = 0; i < 4; i++) {
        r[i] = wa * a[i] + wb * b[i];
        n += r[i] * r[i];
    }
    n = n > 0 ? 1.0 / sqrt(n) : 0.0;
    for (int i = 0; i < 4; i++)
        out[i] = (float)(r[i] * n);
}

void tnd_quat_mul(const float a[4], const float b[4], float out[4])
{
    float r[4] = {a[3] * b[0] + a[0] * b[3] + a[1] * b[2] - a[2] * b[1],
                  a[3] * b[1] - a[0] * b[2] + a[1] * b[3] + a[2] * b[0],
                  a[3] * b[2] + a[0] * b[1] - a[1] * b[0] + a[2] * b[3],
                  a[3] * b[3] - a[0] * b[0] - a[1] * b[1] - a[2] * b[2]};
    memcpy(out, r, sizeof r);
}

bool tnd_quat_look_at(const double eye[3], const double target[3], float q[4])
{
    /* the camera's +Z (it looks down -Z) points from the target to the eye; up is +Y */
    double b[3] = {eye[0] - target[0], eye[1] - target[1], eye[2] - target[2]};
    double bl = sqrt(b[0] * b[0] + b[1] * b[1] + b[2] * b[2]);
    double rl = sqrt(b[2] * b[2] + b[0] * b[0]);
    if (!(bl > 0) || !(rl > 1e-9 * bl))
        return false;
    for (int k = 0; k < 3; k++)
        b[k] /= bl;
    rl = sqrt(b[2] * b[2] + b[0] * b[0]);
    double rt[3] = {b[2] / rl, 0, -b[0] / rl}; /* (0, 1, 0) x b, normalised */
    double up[3] = {b[1] * rt[2] - b[2] * rt[1], b[2] * rt[0] - b[0] * rt[2],
                    b[0] * rt[1] - b[1] * rt[0]};
    /* the rotation matrix (columns right, up, back) as a quaternion: Shepperd's method, from the
     * largest of w, x, y, z so that no division is by a small number */
    double m[3][3] = {{rt[0], up[0], b[0]}, {rt[1], up[1], b[1]}, {rt[2], up[2], b[2]}};
    double tr = m[0][0] + m[1][1] + m[2][2], x, y, z, w;
    if (tr >= m[0][0] && tr >= m[1][1] && tr >= m[2][2]) {
        w = 0.5 * sqrt(1 + tr);
        x = (m[2][1] - m[1][2]) / (4 * w), y = (m[0][2] - m[2][0]) / (4 * w);
        z = (m[1][0] - m[0][1]) / (4 * w);
    } else if (m[0][0] >= m[1][1] && m[0][0] >= m[2][2]) {
        x = 0.5 * sqrt(1 + m[0][0] - m[1][1] - m[2][2]);
        w = (m[2][1] - m[1][2]) / (4 * x), y = (m[0][1] + m[1][0]) / (4 * x);
        z = (m[0][2] + m[2][0]) / (4 * x);
    } else if (m[1][1] >= m[2][2]) {
        y = 0.5 * sqrt(1 - m[0][0] + m[1][1] - m[2][2]);
        w = (m[0][2] - m[2][0]) / (4 * y), x = (m[0][1] + m[1][0]) / (4 * y);
        z = (m[1][2] + m[2][1]) / (4 * y);
    } else {
        z = 0.5 * sqrt(1 - m[0][0] - m[1][1] + m[2][2]);
        w = (m[1][0] - m[0][1]) / (4 * z), x = (m[0][2] + m[2][0]) / (4 * z);
        y = (m[1][2] + m[2][1]) / (4 * z);
    }
    double n = sqrt(x * x + y * y + z * z + w * w);
    q[0] = (float)(x / n), q[1] = (float)(y / n), q[2] = (float)(z / n), q[3] = (float)(w / n);
    return true;
}

void tnd_camera_ray(const tnd_camera_state *c, uint32_t width, uint32_t height, float px, float py,
                    float origin[3], float dir[3])
{
    /* Unproject in view space, then rotate: no translation enters the direction, so cameras far
     * from the origin keep full precision. */
    float inv_proj[16], inv_view[16];
    tnd_mat4_inverse(c->proj, inv_proj);
    tnd_mat4_inverse(c->view, inv_view);
    const float zero[3] = {0, 0, 0};
    tnd_mat4_point(inv_view, zero, false, origin);
    float ndc[3] = {2.0f * px / (float)width - 1.0f, 2.0f * py / (float)height - 1.0f, 0.5f};
    float pv[3], d[3];
    tnd_mat4_point(inv_proj, ndc, true, pv);
    tnd_mat4_dir(inv_view, pv, d);
    double n = sqrt((double)d[0] * d[0] + (double)d[1] * d[1] + (double)d[2] * d[2]);
    for (int i = 0; i < 3; i++)
        dir[i] = n > 0 ? (float)(d[i] / n) : 0.0f;
}

double tnd_ref_finish(const double *sum_rgb, const double *sum_lum2, size_t n, uint32_t spp,
                      float *rgb, float *lum_se)
{
    double err = 0;
    uint32_t counted = 0;
    for (size_t q = 0; q < n; q++) {
        double m[3];
        for (int k = 0; k < 3; k++)
            m[k] = sum_rgb[3 * q + k] / spp;
        if (rgb)
            for (int k = 0; k < 3; k++)
                rgb[3 * q + k] = (float)m[k];
        double ml = tnd_luminance((float)m[0], (float)m[1], (float)m[2]);
        double se = tnd_ref_pixel_se(ml, sum_lum2[q] / spp, spp);
        if (lum_se)
            lum_se[q] = (float)se;
        if (ml > 1e-6 && spp > 1) {
            err += se / ml;
            counted++;
        }
    }
    return counted ? err / counted : 0;
}

tnd_result tnd_ref_run(size_t n, uint32_t spp, tnd_ref_add_fn add, void *ctx, float *rgb,
                       float *lum_se, tnd_ref_stats *stats,
                       void (*progress)(uint32_t, uint32_t, void *), void *user)
{
    if (spp == 0)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "reference with 0 samples per pixel");
    double *sum = calloc(3 * n, sizeof(double)), *sum2 = calloc(n, sizeof(double));
    tnd_ref_stats st = {.until_noise = stats ? stats->until_noise : 0.0};
    tnd_result res = sum && sum2 ? TND_OK : tnd_fail(TND_ERR_OUT_OF_MEMORY, "reference: out of memory");
    if (res == TND_OK)
        res = add(ctx, 0, spp, sum, sum2, &st, progress, user);
    if (res == TND_OK) {
        st.rel_error = tnd_ref_finish(sum, sum2, n, st.spp, rgb, lum_se);
        if (stats)
            *stats = st;
    }
    free(sum);
    free(sum2);
    return res;
}
