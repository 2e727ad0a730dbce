/* eval/table.c: the metrics as one table (ev_metric): names, headers, plot titles, formats,
 * where each lives in ev_frame_metrics and ev_summary, and who shows it. Definitions of every
 * metric: docs/metrics.md.
 * Entry points: ev_metric_count, ev_metric_at, ev_metric_find, ev_metric_frame,
 * ev_metric_summary, ev_metric_none. */
#include "eval/eval.h"

#include <stddef.h>
#include <string.h>

#define FRAME(f) offsetof(ev_frame_metrics, f)
#define SUMMARY(f) (long)offsetof(ev_summary, f)

/* clang-format off */
static const ev_metric table[] = {
    /* name, head, plot title, text format, frame field, summary field, optional, plotted,
     * summarised, watched */
    {"relmse", "relMSE", "relMSE (linear, eps 0.01), lower is better", "%10.4g",
     FRAME(relmse), SUMMARY(relmse), false, true, true, true},
    {"smape", "SMAPE", "SMAPE (linear), lower is better", "%8.4f",
     FRAME(smape), SUMMARY(smape), false, true, true, false},
    {"rmse", "RMSE", "RMSE (linear), lower is better", "%8.4g",
     FRAME(rmse), SUMMARY(rmse), false, true, true, false},
    {"psnr", "PSNR dB", "PSNR (tone-mapped sRGB, dB), higher is better", "%8.2f",
     FRAME(psnr), SUMMARY(psnr), false, true, true, false},
    {"ssim", "SSIM", "SSIM (tone-mapped sRGB), higher is better", "%7.4f",
     FRAME(ssim), SUMMARY(ssim), false, true, true, false},
    {"flip", "FLIP", "LDR-FLIP (67 ppd), lower is better", "%7.4f",
     FRAME(flip), SUMMARY(flip), false, true, true, true},
    {"temporal", "temporal", "temporal error (tone-mapped), lower is better", "%9.4g",
     FRAME(temporal), SUMMARY(temporal), true, true, true, true},
    {"mc_temporal", "temporal (motion-comp.)",
     "motion-compensated temporal error (tone-mapped), lower is better", "%9.4g",
     FRAME(mc_temporal), SUMMARY(mc_temporal), true, false, false, true},
    {"worth_relmse", "worth relMSE",
     "worth N samples by relMSE (luminance; the plain average's spp), higher is better", "%12.4g",
     FRAME(worth_relmse), SUMMARY(worth_relmse), true, true, true, false},
    {"worth_flip", "worth FLIP",
     "worth N samples by FLIP (the plain average's spp, modelled), higher is better", "%10.4g",
     FRAME(worth_flip), SUMMARY(worth_flip), true, true, true, false},
    {"disoccluded", "disoccluded", "disoccluded fraction of the pixels (the reference's motion)",
     "%8.4f", FRAME(disoccluded), -1, true, false, false, false},
};
/* clang-format on */
enum { METRICS = sizeof table / sizeof table[0] };

uint32_t ev_metric_count(void)
{
    return METRICS;
}

const ev_metric *ev_metric_at(uint32_t i)
{
    return i < METRICS ? &table[i] : NULL;
}

const ev_metric *ev_metric_find(const char *name)
{
    for (int i = 0; i < METRICS; i++)
        if (strcmp(table[i].name, name) == 0)
            return &table[i];
    return NULL;
}

double ev_metric_frame(const ev_metric *m, const ev_frame_metrics *f)
{
    return *(const double *)((const char *)f + m->frame);
}

double ev_metric_summary(const ev_metric *m, const ev_summary *s)
{
    return m->summary < 0 ? -1.0 : *(const double *)((const char *)s + m->summary);
}

bool ev_metric_none(const ev_metric *m, double v)
{
    return m->optional && v < 0;
}
