/* eval/report.c: what `tandem eval`, `compare` and `bench --sweep` write: metrics.json and
 * metrics.csv, PNGs, SVG plots (per-frame metrics, Pareto fronts), and the static HTML page.
 * Entry points: ev_write_metrics, ev_write_png, ev_colormap, ev_plot_metric, ev_plot_pareto,
 * ev_pareto, ev_report_write, ev_text_*. */
#include "eval/eval.h"

#include <cjson/cJSON.h>
#include <math.h>
#include <stb/stb_image_write.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---- text buffer ---------------------------------------------------------------------------- */
void ev_text_add(ev_text *t, const char *fmt, ...)
{
    if (t->failed)
        return;
    va_list ap;
    va_start(ap, fmt);
    int n = vsnprintf(NULL, 0, fmt, ap);
    va_end(ap);
    if (n < 0) {
        t->failed = true;
        return;
    }
    if (t->len + (size_t)n + 1 > t->cap) {
        size_t cap = (t->cap ? t->cap * 2 : 4096) + (size_t)n;
        char *s = realloc(t->s, cap);
        if (!s) {
            t->failed = true;
            return;
        }
        t->s = s;
        t->cap = cap;
    }
    va_start(ap, fmt);
    vsnprintf(t->s + t->len, t->cap - t->len, fmt, ap);
    va_end(ap);
    t->len += (size_t)n;
}

void ev_text_escaped(ev_text *t, const char *raw)
{
    for (const char *p = raw; p && *p; p++) {
        switch (*p) {
        case '<': ev_text_add(t, "&lt;"); break;
        case '>': ev_text_add(t, "&gt;"); break;
        case '&': ev_text_add(t, "&amp;"); break;
        case '"': ev_text_add(t, "&quot;"); break;
        default: ev_text_add(t, "%c", *p);
        }
    }
}

void ev_text_free(ev_text *t)
{
    free(t->s);
    *t = (ev_text){0};
}

/* Write `text` to PATH atomically (no partial file). */
static tnd_result write_path(const char *path, const ev_text *text)
{
    if (text->failed)
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "eval: %s: out of memory", path);
    return tnd_file_write_atomic(path, text->s ? text->s : "", text->len);
}

static tnd_result write_file(const char *dir, const char *name, const ev_text *text)
{
    char path[4200];
    snprintf(path, sizeof path, "%.2047s/%.2047s", dir, name);
    return write_path(path, text);
}

/* ---- metrics.json / metrics.csv ------------------------------------------------------------- */
/* the metric table's rows (eval/table.c) by index */
#define METRICS ((int)ev_metric_count())
#define metric_name(k) (ev_metric_at((uint32_t)(k))->name)

static double frame_metric(const ev_frame_metrics *f, int k)
{
    return ev_metric_frame(ev_metric_at((uint32_t)k), f);
}

static double summary_metric(const ev_summary *s, int k)
{
    return ev_metric_summary(ev_metric_at((uint32_t)k), s);
}

/* temporal, mc_temporal: none for the first frame (or without motion); null in JSON */
static bool metric_missing(int k, double v)
{
    return ev_metric_none(ev_metric_at((uint32_t)k), v);
}

tnd_result ev_write_metrics(const char *dir, const ev_series *s, uint32_t nseries, uint32_t count,
                            const char *settings)
{
    cJSON *root = cJSON_CreateObject();
    cJSON *set = settings ? cJSON_Parse(settings) : NULL;
    cJSON_AddItemToObject(root, "settings", set ? set : cJSON_CreateObject());
    cJSON *arr = cJSON_AddArrayToObject(root, "series");
    ev_text csv = {0};
    ev_text_add(&csv, "series,frame");
    for (int k = 0; k < METRICS; k++)
        ev_text_add(&csv, ",%s", metric_name(k));
    ev_text_add(&csv, ",nonfinite\n");
    for (uint32_t i = 0; i < nseries; i++) {
        cJSON *o = cJSON_CreateObject();
        cJSON_AddItemToArray(arr, o);
        cJSON_AddStringToObject(o, "name", s[i].name);
        cJSON *sum = cJSON_AddObjectToObject(o, "summary");
        for (int k = 0; k < METRICS; k++) {
            double v = summary_metric(&s[i].summary, k);
            if (metric_missing(k, v))
                cJSON_AddNullToObject(sum, metric_name(k));
            else
                cJSON_AddNumberToObject(sum, metric_name(k), v);
        }
        const ev_summary *sm = &s[i].summary;
        cJSON_AddNumberToObject(sum, "flicker", sm->flicker);
        cJSON_AddNumberToObject(sum, "flicker_reference", sm->flicker_ref);
        cJSON_AddNumberToObject(sum, "static_pixels", (double)sm->static_pixels);
        cJSON_AddNumberToObject(sum, "disocclusion_lag", sm->disocclusion_lag);
        cJSON_AddNumberToObject(sum, "disocclusions", sm->disocclusions);
        cJSON_AddNumberToObject(sum, "lag", s[i].summary.lag);
        cJSON_AddNumberToObject(sum, "lighting_changes", s[i].summary.changes);
        cJSON_AddNumberToObject(sum, "nonfinite", (double)s[i].summary.nonfinite);
        cJSON *reg = s[i].regions ? cJSON_Parse(s[i].regions) : NULL;
        if (reg)
            cJSON_AddItemToObject(o, "regions", reg);
        cJSON *fr = cJSON_AddArrayToObject(o, "frames");
        for (uint32_t f = 0; f < count; f++) {
            const ev_frame_metrics *m = &s[i].m[f];
            cJSON *x = cJSON_CreateObject();
            cJSON_AddItemToArray(fr, x);
            cJSON_AddNumberToObject(x, "frame", m->frame);
            ev_text_add(&csv, "%s,%u", s[i].name, m->frame);
            for (int k = 0; k < METRICS; k++) {
                double v = frame_metric(m, k);
                if (metric_missing(k, v)) { /* no temporal error for the first frame */
                    cJSON_AddNullToObject(x, metric_name(k));
                    ev_text_add(&csv, ",");
                } else {
                    cJSON_AddNumberToObject(x, metric_name(k), v);
                    ev_text_add(&csv, ",%.9g", v);
                }
            }
            cJSON_AddNumberToObject(x, "nonfinite", (double)m->nonfinite);
            ev_text_add(&csv, ",%llu\n", (unsigned long long)m->nonfinite);
        }
    }
    for (uint32_t i = 0; i < nseries; i++) {
        ev_text_add(&csv, "%s,mean", s[i].name);
        for (int k = 0; k < METRICS; k++) {
            double v = summary_metric(&s[i].summary, k);
            if (metric_missing(k, v))
                ev_text_add(&csv, ",");
            else
                ev_text_add(&csv, ",%.9g", v);
        }
        ev_text_add(&csv, ",%llu\n", (unsigned long long)s[i].summary.nonfinite);
    }
    char *txt = cJSON_Print(root);
    cJSON_Delete(root);
    ev_text json = {0};
    if (txt)
        ev_text_add(&json, "%s\n", txt);
    else
        json.failed = true;
    free(txt);
    tnd_result res = write_file(dir, "metrics.json", &json);
    if (res == TND_OK)
        res = write_file(dir, "metrics.csv", &csv);
    ev_text_free(&json);
    ev_text_free(&csv);
    return res;
}

/* ---- images --------------------------------------------------------------------------------- */
tnd_result ev_write_png(const char *path, const float *rgb, uint32_t w, uint32_t h)
{
    size_t n = (size_t)w * h * 3;
    uint8_t *px = malloc(n);
    if (!px)
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "eval: out of memory");
    for (size_t i = 0; i < n; i++) {
        float v = isfinite(rgb[i]) ? rgb[i] : 0.0f;
        px[i] = (uint8_t)fminf(255.0f, floorf(fmaxf(v, 0.0f) * 255.0f + 0.5f));
    }
    char tmp[2200];
    snprintf(tmp, sizeof tmp, "%s.tmp", path);
    int ok = stbi_write_png(tmp, (int)w, (int)h, 3, px, (int)w * 3);
    free(px);
    if (!ok || rename(tmp, path) != 0) {
        remove(tmp);
        return tnd_fail(TND_ERR_IO, "eval: %s: cannot write", path);
    }
    return TND_OK;
}

void ev_colormap(const float *err, size_t n, float *rgb)
{
    /* control points of a magma-like ramp, evenly spaced over [0, 1] */
    static const float cp[6][3] = {{0.00f, 0.00f, 0.02f}, {0.23f, 0.06f, 0.44f},
                                   {0.55f, 0.16f, 0.51f}, {0.87f, 0.29f, 0.41f},
                                   {0.99f, 0.62f, 0.36f}, {0.99f, 0.99f, 0.75f}};
    for (size_t q = 0; q < n; q++) {
        float e = isfinite(err[q]) ? fminf(fmaxf(err[q], 0.0f), 1.0f) : 1.0f;
        float x = e * 5.0f;
        int i = (int)fminf(floorf(x), 4.0f);
        float t = x - (float)i;
        for (int k = 0; k < 3; k++)
            rgb[3 * q + k] = cp[i][k] + (cp[i + 1][k] - cp[i][k]) * t;
    }
}

/* ---- SVG plots ------------------------------------------------------------------------------ */
static const char *const palette[] = {"#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e",
                                      "#8c564b", "#e377c2", "#17becf"};

typedef struct axis {
    double lo, hi;
    bool log;
} axis;

static double axis_pos(const axis *a, double v, double p0, double p1)
{
    double t;
    if (a->log)
        t = (log10(fmax(v, 1e-30)) - log10(a->lo)) / (log10(a->hi) - log10(a->lo));
    else
        t = (v - a->lo) / (a->hi - a->lo);
    return p0 + t * (p1 - p0);
}

static void axis_fit(axis *a, const double *v, size_t n, bool log_scale)
{
    a->log = log_scale;
    a->lo = INFINITY;
    a->hi = -INFINITY;
    for (size_t i = 0; i < n; i++) {
        if (!isfinite(v[i]) || (log_scale && !(v[i] > 0)))
            continue;
        a->lo = fmin(a->lo, v[i]);
        a->hi = fmax(a->hi, v[i]);
    }
    if (!(a->lo <= a->hi)) {
        a->lo = log_scale ? 1e-3 : 0;
        a->hi = 1;
    }
    if (log_scale) {
        a->lo = pow(10, floor(log10(a->lo)));
        a->hi = pow(10, ceil(log10(a->hi)));
        if (a->hi <= a->lo)
            a->hi = a->lo * 10;
    } else {
        double pad = (a->hi - a->lo) * 0.05;
        if (pad == 0)
            pad = fabs(a->hi) * 0.05 + 1e-6;
        a->lo -= pad;
        a->hi += pad;
    }
}

enum { PW = 680, PH = 320, ML = 70, MR = 150, MT = 30, MB = 45 }; /* legend in the right margin */

static void svg_frame(ev_text *t, const char *title, const char *xlabel, const char *ylabel,
                      const axis *ax, const axis *ay)
{
    ev_text_add(t,
                "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"%d\" height=\"%d\" "
                "viewBox=\"0 0 %d %d\" font-family=\"sans-serif\" font-size=\"11\">\n"
                "<rect width=\"100%%\" height=\"100%%\" fill=\"white\"/>\n",
                PW, PH, PW, PH);
    ev_text_add(t, "<text x=\"%d\" y=\"18\" font-size=\"13\" font-weight=\"bold\">", ML);
    ev_text_escaped(t, title);
    ev_text_add(t, "</text>\n");
    int x0 = ML, x1 = PW - MR, y0 = PH - MB, y1 = MT;
    ev_text_add(t, "<rect x=\"%d\" y=\"%d\" width=\"%d\" height=\"%d\" fill=\"none\" stroke=\"#444\"/>\n",
                x0, y1, x1 - x0, y0 - y1);
    const axis *axes[2] = {ax, ay};
    for (int d = 0; d < 2; d++) {
        const axis *a = axes[d];
        double ticks[16];
        int nt = 0;
        if (a->log) {
            for (double v = a->lo; v <= a->hi * 1.0001 && nt < 16; v *= 10)
                ticks[nt++] = v;
        } else {
            double span = a->hi - a->lo, step = pow(10, floor(log10(span / 5)));
            if (span / step > 10)
                step *= 2;
            if (span / step > 10)
                step *= 2.5;
            for (double v = ceil(a->lo / step) * step; v <= a->hi && nt < 16; v += step)
                ticks[nt++] = fabs(v) < 1e-9 * step ? 0.0 : v; /* no "-0" */
        }
        for (int i = 0; i < nt; i++) {
            if (d == 0) {
                double x = axis_pos(a, ticks[i], x0, x1);
                ev_text_add(t, "<line x1=\"%.1f\" y1=\"%d\" x2=\"%.1f\" y2=\"%d\" stroke=\"#ddd\"/>"
                               "<text x=\"%.1f\" y=\"%d\" text-anchor=\"middle\">%.4g</text>\n",
                            x, y0, x, y1, x, y0 + 14, ticks[i]);
            } else {
                double y = axis_pos(a, ticks[i], y0, y1);
                ev_text_add(t, "<line x1=\"%d\" y1=\"%.1f\" x2=\"%d\" y2=\"%.1f\" stroke=\"#ddd\"/>"
                               "<text x=\"%d\" y=\"%.1f\" text-anchor=\"end\">%.4g</text>\n",
                            x0, y, x1, y, x0 - 4, y + 4, ticks[i]);
            }
        }
    }
    ev_text_add(t, "<text x=\"%d\" y=\"%d\" text-anchor=\"middle\">", (x0 + x1) / 2, PH - 8);
    ev_text_escaped(t, xlabel);
    ev_text_add(t, "</text>\n<text transform=\"translate(14 %d) rotate(-90)\" text-anchor=\"middle\">",
                (y0 + y1) / 2);
    ev_text_escaped(t, ylabel);
    ev_text_add(t, "</text>\n");
}

static tnd_result write_svg(const char *path, ev_text *t)
{
    ev_text_add(t, "</svg>\n");
    return write_path(path, t);
}

tnd_result ev_plot_metric(const char *path, const char *metric, const ev_series *s,
                          uint32_t nseries, uint32_t count)
{
    const ev_metric *em = ev_metric_find(metric);
    if (!em)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "eval: no metric '%s'", metric);
    int k = (int)(em - ev_metric_at(0));
    double *v = calloc((size_t)nseries * count + 2, sizeof(double));
    double *fr = calloc((size_t)count + 2, sizeof(double));
    if (!v || !fr) {
        free(v);
        free(fr);
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "eval: out of memory");
    }
    for (uint32_t i = 0; i < nseries; i++)
        for (uint32_t f = 0; f < count; f++) {
            double x = frame_metric(&s[i].m[f], k);
            v[i * count + f] = metric_missing(k, x) ? NAN : x;
        }
    for (uint32_t f = 0; f < count; f++)
        fr[f] = nseries ? s[0].m[f].frame : f;
    bool log_y = k == 0 || k == 2; /* relMSE and RMSE span decades */
    axis ax, ay;
    axis_fit(&ax, fr, count, false);
    axis_fit(&ay, v, (size_t)nseries * count, log_y);
    ev_text t = {0};
    svg_frame(&t, em->title, "frame", metric, &ax, &ay);
    int x0 = ML, x1 = PW - MR, y0 = PH - MB, y1 = MT;
    for (uint32_t i = 0; i < nseries; i++) {
        const char *col = palette[i % 8];
        ev_text_add(&t, "<polyline fill=\"none\" stroke=\"%s\" stroke-width=\"1.5\" points=\"", col);
        for (uint32_t f = 0; f < count; f++) {
            double y = v[i * count + f];
            if (isfinite(y) && (!log_y || y > 0))
                ev_text_add(&t, "%.1f,%.1f ", axis_pos(&ax, fr[f], x0, x1), axis_pos(&ay, y, y0, y1));
        }
        ev_text_add(&t, "\"/>\n");
        for (uint32_t f = 0; f < count; f++) {
            double y = v[i * count + f];
            if (isfinite(y) && (!log_y || y > 0))
                ev_text_add(&t, "<circle cx=\"%.1f\" cy=\"%.1f\" r=\"2\" fill=\"%s\"/>",
                            axis_pos(&ax, fr[f], x0, x1), axis_pos(&ay, y, y0, y1), col);
        }
        ev_text_add(&t, "\n<rect x=\"%d\" y=\"%u\" width=\"10\" height=\"10\" fill=\"%s\"/>"
                        "<text x=\"%d\" y=\"%u\">",
                    x1 + 8, (unsigned)(y1 + 2 + 14 * i), col, x1 + 22, (unsigned)(y1 + 11 + 14 * i));
        ev_text_escaped(&t, s[i].name);
        ev_text_add(&t, "</text>\n");
    }
    free(v);
    free(fr);
    tnd_result res = write_svg(path, &t);
    ev_text_free(&t);
    return res;
}

void ev_pareto(const double *x, const double *y, uint32_t n, bool *pareto)
{
    for (uint32_t i = 0; i < n; i++) {
        pareto[i] = isfinite(x[i]) && isfinite(y[i]);
        for (uint32_t j = 0; j < n && pareto[i]; j++)
            if (j != i && x[j] <= x[i] && y[j] <= y[i] && (x[j] < x[i] || y[j] < y[i]))
                pareto[i] = false;
    }
}

tnd_result ev_plot_pareto(const char *path, const char *title, const char *xlabel,
                          const char *ylabel, const double *x, const double *y,
                          const char *const *labels, const bool *pareto, uint32_t n, bool log_x,
                          bool log_y)
{
    axis ax, ay;
    axis_fit(&ax, x, n, log_x);
    axis_fit(&ay, y, n, log_y);
    ev_text t = {0};
    svg_frame(&t, title, xlabel, ylabel, &ax, &ay);
    int x0 = ML, x1 = PW - MR, y0 = PH - MB, y1 = MT;
    /* the front, in increasing x */
    uint32_t *idx = malloc((size_t)n * sizeof *idx + 4);
    uint32_t m = 0;
    for (uint32_t i = 0; idx && i < n; i++)
        if (pareto[i])
            idx[m++] = i;
    for (uint32_t a = 1; idx && a < m; a++)
        for (uint32_t b = a; b > 0 && x[idx[b - 1]] > x[idx[b]]; b--) {
            uint32_t tmp = idx[b];
            idx[b] = idx[b - 1];
            idx[b - 1] = tmp;
        }
    ev_text_add(&t, "<polyline fill=\"none\" stroke=\"#d62728\" stroke-width=\"1.5\" points=\"");
    for (uint32_t a = 0; idx && a < m; a++)
        ev_text_add(&t, "%.1f,%.1f ", axis_pos(&ax, x[idx[a]], x0, x1),
                    axis_pos(&ay, y[idx[a]], y0, y1));
    ev_text_add(&t, "\"/>\n");
    free(idx);
    for (uint32_t i = 0; i < n; i++) {
        if (!isfinite(x[i]) || !isfinite(y[i]))
            continue;
        double px = axis_pos(&ax, x[i], x0, x1), py = axis_pos(&ay, y[i], y0, y1);
        ev_text_add(&t, "<circle cx=\"%.1f\" cy=\"%.1f\" r=\"%d\" fill=\"%s\"><title>", px, py,
                    pareto[i] ? 4 : 3, pareto[i] ? "#d62728" : "#1f77b4");
        ev_text_escaped(&t, labels[i]);
        ev_text_add(&t, "</title></circle>");
        if (pareto[i]) {
            ev_text_add(&t, "<text x=\"%.1f\" y=\"%.1f\" font-size=\"9\">", px + 5, py - 4);
            ev_text_escaped(&t, labels[i]);
            ev_text_add(&t, "</text>");
        }
        ev_text_add(&t, "\n");
    }
    tnd_result res = write_svg(path, &t);
    ev_text_free(&t);
    return res;
}

/* ---- the HTML page -------------------------------------------------------------------------- */
tnd_result ev_report_write(const ev_report *r)
{
    ev_text t = {0};
    ev_text_add(&t, "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>");
    ev_text_escaped(&t, r->title);
    ev_text_add(&t,
                "</title>\n<style>\nbody{font-family:sans-serif;margin:20px;color:#222}"
                "table{border-collapse:collapse}td,th{border:1px solid #ccc;padding:3px 8px;"
                "text-align:right}th{background:#f4f4f4}td:first-child,th:first-child{text-align:left}"
                ".row{display:flex;flex-wrap:wrap;gap:8px}figure{margin:0}"
                "figcaption{font-size:12px;text-align:center}"
                "img.px{image-rendering:pixelated}pre{background:#f8f8f8;padding:8px;"
                "max-height:320px;overflow:auto;font-size:11px}\n</style>\n"
                "<script>\nwindow.tndErrors=[];\n"
                "window.addEventListener('error',function(e){tndErrors.push(String(e.message||"
                "(e.target&&e.target.src)||'error'));},true);\n"
                "window.addEventListener('load',function(){var im=Array.prototype.slice.call("
                "document.images);var bad=im.filter(function(i){return !i.complete||"
                "i.naturalWidth===0;});var b=document.body;b.setAttribute('data-images',im.length);"
                "b.setAttribute('data-broken',bad.map(function(i){return i.getAttribute('src');})"
                ".join(' '));b.setAttribute('data-status',bad.length||tndErrors.length?'error':'ok');"
                "});\n</script>\n</head>\n<body>\n<h1>");
    ev_text_escaped(&t, r->title);
    ev_text_add(&t, "</h1>\n");
    if (r->series && r->nseries) {
        ev_text_add(&t, "<h2>Summary (means over frames)</h2>\n<table><tr><th>series</th>");
        for (int k = 0; k < METRICS; k++) /* (the metrics with a mean) */
            if (ev_metric_at((uint32_t)k)->summary >= 0)
                ev_text_add(&t, "<th>%s</th>", ev_metric_at((uint32_t)k)->head);
        ev_text_add(&t, "<th>flicker (static pixels; reference)</th><th>lag after a "
                        "disocclusion</th><th>lag (frames)</th><th>non-finite</th></tr>\n");
        for (uint32_t i = 0; i < r->nseries; i++) {
            ev_text_add(&t, "<tr><td>");
            ev_text_escaped(&t, r->series[i].name);
            ev_text_add(&t, "</td>");
            for (int k = 0; k < METRICS; k++) {
                if (ev_metric_at((uint32_t)k)->summary < 0)
                    continue;
                double v = summary_metric(&r->series[i].summary, k);
                if (metric_missing(k, v))
                    ev_text_add(&t, "<td>-</td>");
                else
                    ev_text_add(&t, "<td>%.5g</td>", v);
            }
            const ev_summary *sm = &r->series[i].summary;
            if (sm->flicker >= 0)
                ev_text_add(&t, "<td>%.4g (%.4g)</td>", sm->flicker, sm->flicker_ref);
            else
                ev_text_add(&t, "<td>-</td>");
            if (sm->disocclusion_lag >= 0)
                ev_text_add(&t, "<td>%.2f (%u)</td>", sm->disocclusion_lag, sm->disocclusions);
            else
                ev_text_add(&t, "<td>-</td>");
            if (r->series[i].summary.lag >= 0)
                ev_text_add(&t, "<td>%.2f (%u change%s)</td>", r->series[i].summary.lag,
                            r->series[i].summary.changes, r->series[i].summary.changes == 1 ? "" : "s");
            else
                ev_text_add(&t, "<td>no lighting change</td>");
            ev_text_add(&t, "<td>%llu</td></tr>\n", (unsigned long long)r->series[i].summary.nonfinite);
        }
        ev_text_add(&t, "</table>\n<p>Definitions: docs/metrics.md. Per-frame values: "
                        "<a href=\"metrics.csv\">metrics.csv</a>, "
                        "<a href=\"metrics.json\">metrics.json</a>.</p>\n");
    }
    if (r->html)
        ev_text_add(&t, "%s\n", r->html);
    if (r->nplots) {
        ev_text_add(&t, "<h2>Per frame</h2>\n<div class=\"row\">\n");
        for (uint32_t i = 0; i < r->nplots; i++) {
            ev_text_add(&t, "<img src=\"");
            ev_text_escaped(&t, r->plots[i]);
            ev_text_add(&t, "\" alt=\"");
            ev_text_escaped(&t, r->plots[i]);
            ev_text_add(&t, "\" width=\"%d\" height=\"%d\">\n", PW, PH);
        }
        ev_text_add(&t, "</div>\n");
    }
    for (uint32_t i = 0; i < r->nrows; i++) {
        const ev_row *row = &r->rows[i];
        ev_text_add(&t, "<h2>");
        ev_text_escaped(&t, row->title);
        ev_text_add(&t, "</h2>\n<div class=\"row\">\n");
        for (uint32_t k = 0; k < row->count; k++) {
            ev_text_add(&t, "<figure><img class=\"px\" src=\"");
            ev_text_escaped(&t, row->panels[k].file);
            if (row->panels[k].display_width)
                ev_text_add(&t, "\" width=\"%u", row->panels[k].display_width);
            ev_text_add(&t, "\" alt=\"");
            ev_text_escaped(&t, row->panels[k].caption);
            ev_text_add(&t, "\"><figcaption>");
            ev_text_escaped(&t, row->panels[k].caption);
            ev_text_add(&t, "</figcaption></figure>\n");
        }
        ev_text_add(&t, "</div>\n");
    }
    if (r->settings) {
        ev_text_add(&t, "<h2>Settings</h2>\n<pre>");
        ev_text_escaped(&t, r->settings);
        ev_text_add(&t, "</pre>\n");
    }
    ev_text_add(&t, "</body></html>\n");
    tnd_result res = write_file(r->dir, "index.html", &t);
    ev_text_free(&t);
    return res;
}
