/* ev_metrics.comp: eval's per-frame metrics on the device (eval/metrics_gpu.c), the same
 * definitions as the CPU's (eval/metrics.c, docs/metrics.md) in four passes over storage-buffer
 * planes of n = w x h floats:
 *   0 prep:   the pointwise terms (relMSE, SMAPE, squared error; on linear radiance), the tone
 *             mapping of both images, their squared difference, YCxCz and FLIP's luminance;
 *   1 rows:   the horizontal halves of the separable filters: FLIP's contrast sensitivity (4
 *             terms per image), its edge / point / smoothing kernels on the luminance, SSIM's
 *             five moments per channel (interior columns only: its windows must fit);
 *   2 cols:   the vertical halves, then FLIP per pixel (colour difference ^ (1 - feature)) and
 *             SSIM's index summed over the channels (interior pixels; 0 elsewhere);
 *   3 reduce: per workgroup, the sums of the six result planes (the host adds the groups in
 *             double). */
#version 460
layout(local_size_x = 256) in;

layout(set = 0, binding = 0, std430) readonly buffer InO { float in_o[]; };
layout(set = 0, binding = 1, std430) readonly buffer InR { float in_r[]; };
layout(set = 0, binding = 2, std430) buffer Planes { float pl[]; };
layout(set = 0, binding = 3, std430) readonly buffer Kern { float kern[]; };
layout(set = 0, binding = 4, std430) writeonly buffer Partial { float partial[]; };
layout(push_constant) uniform Push {
    uint pass, w, h, groups;
    float exposure, cmax;
    int rc, rf; /* radii: the contrast sensitivity's, the features' */
} pc;

/* planes */
const uint P_YCC = 0u;    /* 0-2 reference Y', Cx, Cz; 3-5 output */
const uint P_LUM = 6u;    /* 6 reference, 7 output: (Y' + 16) / 116 */
const uint P_TM = 8u;     /* 8-10 reference tone-mapped RGB, 11-13 output */
const uint P_CSF_H = 14u; /* 14-17 reference A, RG, BY1, BY2 filtered along rows; 18-21 output */
const uint P_FEAT_H = 22u; /* 22-24 reference edge, point, smooth along rows; 25-27 output */
const uint P_SSIM_H = 28u; /* 28-42: channel c's mo, mr, mo^2, mr^2, mo mr at 28 + 5c */
const uint P_RES = 43u;   /* 43 FLIP, 44 SSIM (3 channels summed), 45 relMSE (3 summed), 46 SMAPE,
                             47 squared error linear, 48 squared error tone-mapped */
/* kernels: 4 CSF Gaussians (2 rc + 1 each), their 4 weights, edge, point, smooth (2 rf + 1
 * each), SSIM's Gaussian (11) */
uint k_csf(uint t) { return t * uint(2 * pc.rc + 1); }
uint k_weight() { return 4u * uint(2 * pc.rc + 1); }
uint k_feat(uint t) { return k_weight() + 4u + t * uint(2 * pc.rf + 1); }
uint k_ssim() { return k_feat(3u); }

float P(uint k, uint q) { return pl[k * pc.w * pc.h + q]; }
void S(uint k, uint q, float v) { pl[k * pc.w * pc.h + q] = v; }

const vec3 D65 = vec3(0.950428545, 1.0, 1.088900371);

float tonemap(float v)
{
    float x = max(v * pc.exposure, 0.0);
    float y = x <= 1e18 ? x * (2.51 * x + 0.03) / (x * (2.43 * x + 0.59) + 0.14) : 1.0;
    y = clamp(y, 0.0, 1.0);
    float s = y <= 0.0031308 ? 12.92 * y : (y >= 1.0 ? 1.0 : 1.055 * pow(y, 1.0 / 2.4) - 0.055);
    return clamp(s, 0.0, 1.0);
}

vec3 ycxcz(vec3 c)
{
    vec3 l;
    for (int k = 0; k < 3; k++)
        l[k] = c[k] > 0.04045 ? pow((c[k] + 0.055) / 1.055, 2.4) : c[k] / 12.92;
    vec3 xyz = vec3((10135552.0 * l.x + 8788810.0 * l.y + 4435075.0 * l.z) / 24577794.0,
                    (2613072.0 * l.x + 8788810.0 * l.y + 887015.0 * l.z) / 12288897.0,
                    (1425312.0 * l.x + 8788810.0 * l.y + 70074185.0 * l.z) / 73733382.0) / D65;
    return vec3(116.0 * xyz.y - 16.0, 500.0 * (xyz.x - xyz.y), 200.0 * (xyz.y - xyz.z));
}

vec3 hunt_lab(vec3 ycc)
{
    float y = (ycc.x + 16.0) / 116.0;
    vec3 xyz = vec3(y + ycc.y / 500.0, y, y - ycc.z / 200.0) * D65;
    vec3 rgb = clamp(vec3(3.241003275 * xyz.x - 1.537398934 * xyz.y - 0.498615861 * xyz.z,
                          -0.969224334 * xyz.x + 1.875930071 * xyz.y + 0.041554224 * xyz.z,
                          0.055639423 * xyz.x - 0.204011202 * xyz.y + 1.057148933 * xyz.z),
                     0.0, 1.0);
    vec3 t = vec3((10135552.0 * rgb.x + 8788810.0 * rgb.y + 4435075.0 * rgb.z) / 24577794.0,
                  (2613072.0 * rgb.x + 8788810.0 * rgb.y + 887015.0 * rgb.z) / 12288897.0,
                  (1425312.0 * rgb.x + 8788810.0 * rgb.y + 70074185.0 * rgb.z) / 73733382.0) / D65;
    const float d = 6.0 / 29.0;
    vec3 f;
    for (int k = 0; k < 3; k++)
        f[k] = t[k] > d * d * d ? pow(t[k], 1.0 / 3.0) : t[k] / (3.0 * d * d) + 4.0 / 29.0;
    float L = 116.0 * f.y - 16.0;
    return vec3(L, 5.0 * L * (f.x - f.y), 2.0 * L * (f.y - f.z));
}

/* a kernel at offset k0 of radius r along x (dx = 1) or y, clamped borders, on plane `src` */
float filt(uint src, uint k0, int r, ivec2 p, ivec2 dir)
{
    float s = 0.0;
    for (int i = -r; i <= r; i++) {
        ivec2 q = clamp(p + dir * i, ivec2(0), ivec2(pc.w, pc.h) - 1);
        s += kern[k0 + uint(i + r)] * P(src, uint(q.y) * pc.w + uint(q.x));
    }
    return s;
}

shared float red[6][256];

void main()
{
    uint n = pc.w * pc.h;
    if (pc.pass == 3u) { /* reduce */
        uint t = gl_LocalInvocationID.x, stride = pc.groups * 256u;
        float s[6] = float[6](0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
        for (uint q = gl_GlobalInvocationID.x; q < n; q += stride)
            for (uint k = 0u; k < 6u; k++)
                s[k] += P(P_RES + k, q);
        for (uint k = 0u; k < 6u; k++)
            red[k][t] = s[k];
        barrier();
        for (uint m = 128u; m > 0u; m >>= 1) {
            if (t < m)
                for (uint k = 0u; k < 6u; k++)
                    red[k][t] += red[k][t + m];
            barrier();
        }
        if (t == 0u)
            for (uint k = 0u; k < 6u; k++)
                partial[gl_WorkGroupID.x * 6u + k] = red[k][0];
        return;
    }
    uint q = gl_GlobalInvocationID.x;
    if (q >= n)
        return;
    ivec2 p = ivec2(int(q % pc.w), int(q / pc.w));
    if (pc.pass == 0u) { /* prep */
        vec3 o = vec3(in_o[3u * q], in_o[3u * q + 1u], in_o[3u * q + 2u]);
        vec3 r = vec3(in_r[3u * q], in_r[3u * q + 1u], in_r[3u * q + 2u]);
        vec3 d = o - r;
        S(P_RES + 2u, q, dot(d * d / (r * r + 0.01), vec3(1.0)));
        S(P_RES + 3u, q, dot(abs(d) / (abs(o) + abs(r) + 0.01), vec3(1.0)));
        S(P_RES + 4u, q, dot(d, d));
        vec3 to, tr;
        for (int k = 0; k < 3; k++)
            to[k] = tonemap(o[k]), tr[k] = tonemap(r[k]);
        vec3 dt = to - tr;
        S(P_RES + 5u, q, dot(dt, dt));
        vec3 yr = ycxcz(tr), yo = ycxcz(to);
        for (uint k = 0u; k < 3u; k++) {
            S(P_TM + k, q, tr[k]);
            S(P_TM + 3u + k, q, to[k]);
            S(P_YCC + k, q, yr[k]);
            S(P_YCC + 3u + k, q, yo[k]);
        }
        S(P_LUM, q, (yr.x + 16.0) / 116.0);
        S(P_LUM + 1u, q, (yo.x + 16.0) / 116.0);
    } else if (pc.pass == 1u) { /* rows */
        for (uint m = 0u; m < 2u; m++) {
            const uint src[4] = uint[4](0u, 1u, 2u, 2u);
            for (uint t = 0u; t < 4u; t++)
                S(P_CSF_H + 4u * m + t, q,
                  filt(P_YCC + 3u * m + src[t], k_csf(t), pc.rc, p, ivec2(1, 0)));
            for (uint t = 0u; t < 3u; t++)
                S(P_FEAT_H + 3u * m + t, q, filt(P_LUM + m, k_feat(t), pc.rf, p, ivec2(1, 0)));
        }
        if (p.x >= 5 && p.x < int(pc.w) - 5)
            for (uint c = 0u; c < 3u; c++) {
                float s[5] = float[5](0.0, 0.0, 0.0, 0.0, 0.0);
                for (int i = -5; i <= 5; i++) {
                    float g = kern[k_ssim() + uint(i + 5)];
                    uint qq = q + uint(i);
                    float a = P(P_TM + 3u + c, qq), b = P(P_TM + c, qq);
                    s[0] += g * a, s[1] += g * b, s[2] += g * a * a, s[3] += g * b * b,
                        s[4] += g * a * b;
                }
                for (uint j = 0u; j < 5u; j++)
                    S(P_SSIM_H + 5u * c + j, q, s[j]);
            }
    } else if (pc.pass == 2u) { /* cols */
        vec3 ycc[2];
        float mag_e[2], mag_p[2];
        for (uint m = 0u; m < 2u; m++) {
            float v[4];
            for (uint t = 0u; t < 4u; t++)
                v[t] = kern[k_weight() + t] * filt(P_CSF_H + 4u * m + t, k_csf(t), pc.rc, p, ivec2(0, 1));
            ycc[m] = vec3(v[0], v[1], v[2] + v[3]);
            uint fh = P_FEAT_H + 3u * m;
            float ex = filt(fh, k_feat(2u), pc.rf, p, ivec2(0, 1));     /* edge along x */
            float ey = filt(fh + 2u, k_feat(0u), pc.rf, p, ivec2(0, 1)); /* edge along y */
            float px = filt(fh + 1u, k_feat(2u), pc.rf, p, ivec2(0, 1));
            float py = filt(fh + 2u, k_feat(1u), pc.rf, p, ivec2(0, 1));
            mag_e[m] = sqrt(ex * ex + ey * ey);
            mag_p[m] = sqrt(px * px + py * py);
        }
        vec3 a = hunt_lab(ycc[0]), b = hunt_lab(ycc[1]);
        float dc = abs(a.x - b.x) + length(a.yz - b.yz);
        float e = pow(dc, 0.7), pcm = 0.4 * pc.cmax;
        float color = e < pcm ? 0.95 / pcm * e : 0.95 + (e - pcm) / (pc.cmax - pcm) * 0.05;
        float f = sqrt(max(abs(mag_e[0] - mag_e[1]), abs(mag_p[0] - mag_p[1])) / sqrt(2.0));
        S(P_RES, q, color > 0.0 ? pow(color, 1.0 - f) : (f >= 1.0 ? 1.0 : 0.0));
        float ssim = 0.0;
        if (p.x >= 5 && p.x < int(pc.w) - 5 && p.y >= 5 && p.y < int(pc.h) - 5)
            for (uint c = 0u; c < 3u; c++) {
                float s[5] = float[5](0.0, 0.0, 0.0, 0.0, 0.0);
                for (int i = -5; i <= 5; i++) {
                    float g = kern[k_ssim() + uint(i + 5)];
                    uint qq = uint(int(q) + i * int(pc.w));
                    for (uint j = 0u; j < 5u; j++)
                        s[j] += g * P(P_SSIM_H + 5u * c + j, qq);
                }
                float mo = s[0], mr = s[1], vo = s[2] - mo * mo, vr = s[3] - mr * mr;
                float cov = s[4] - mo * mr;
                const float c1 = 0.01 * 0.01, c2 = 0.03 * 0.03;
                ssim += (2.0 * mo * mr + c1) * (2.0 * cov + c2) /
                        ((mo * mo + mr * mr + c1) * (vo + vr + c2));
            }
        S(P_RES + 1u, q, ssim);
    }
}
