/* Every shader Tandem builds, written once.
 *
 * X(name, file, defines): `name` becomes the C enum TND_SHADER_<name> and the embedded array
 * tnd_spv_<name>; `file` is the GLSL source in shaders/; `defines` is a space-separated list of
 * NAME=VALUE preprocessor definitions ("" for none), so one source builds several variants.
 * shaders/CMakeLists.txt parses the X(...) lines below to compile them: keep that form. */
#ifndef TND_SHADER_LIST_H
#define TND_SHADER_LIST_H
#include <stddef.h>
#include <stdint.h>

// clang-format off
#define TND_SHADER_LIST(X) \
    X(trace_test_rgen,     "trace_test.rgen",     "") \
    X(trace_test_rchit,    "trace_test.rchit",    "") \
    X(trace_test_rmiss,    "trace_test.rmiss",    "") \
    X(timestamp_test_comp, "timestamp_test.comp", "") \
    X(encoding_test_f32,   "encoding_test.comp",  "TND_PACKED=0") \
    X(encoding_test_packed, "encoding_test.comp", "TND_PACKED=1") \
    X(sampling_test,       "sampling_test.comp",  "") \
    X(pt_primary_f32,      "pt_primary.rgen",     "TND_PACKED=0") \
    X(pt_primary_packed,   "pt_primary.rgen",     "TND_PACKED=1") \
    X(pt_shade_f32,        "pt_shade.rgen",       "TND_PACKED=0") \
    X(pt_shade_packed,     "pt_shade.rgen",       "TND_PACKED=1") \
    X(pt_primary_rq_f32,   "pt_primary_rq.comp",  "TND_PACKED=0") \
    X(pt_primary_rq_packed, "pt_primary_rq.comp", "TND_PACKED=1") \
    X(pt_shade_rq_f32,     "pt_shade_rq.comp",    "TND_PACKED=0") \
    X(pt_shade_rq_packed,  "pt_shade_rq.comp",    "TND_PACKED=1") \
    X(pt_reference,        "pt_reference.rgen",   "TND_PACKED=0") \
    X(pt_reference_rq,     "pt_reference_rq.comp", "TND_PACKED=0") \
    X(ev_metrics,          "ev_metrics.comp",     "") \
    X(pt_matched_f32,      "pt_matched.comp",     "TND_PACKED=0") \
    X(pt_matched_packed,   "pt_matched.comp",     "TND_PACKED=1") \
    X(dn_temporal_f32,     "dn_temporal.comp",    "TND_PACKED=0") \
    X(dn_temporal_packed,  "dn_temporal.comp",    "TND_PACKED=1") \
    X(dn_history_f32,      "dn_history.comp",     "TND_PACKED=0") \
    X(dn_history_packed,   "dn_history.comp",     "TND_PACKED=1") \
    X(dn_atrous_f32,       "dn_atrous.comp",      "TND_PACKED=0") \
    X(dn_atrous_packed,    "dn_atrous.comp",      "TND_PACKED=1") \
    X(dn_composite_f32,    "dn_composite.comp",   "TND_PACKED=0") \
    X(dn_composite_packed, "dn_composite.comp",   "TND_PACKED=1") \
    X(dn_grad_select_f32,  "dn_grad_select.comp", "TND_PACKED=0") \
    X(dn_grad_select_packed, "dn_grad_select.comp", "TND_PACKED=1") \
    X(dn_gradients_f32,    "dn_gradients.comp",   "TND_PACKED=0") \
    X(dn_gradients_packed, "dn_gradients.comp",   "TND_PACKED=1") \
    X(bandwidth_copy,      "bandwidth_copy.comp", "") \
    X(post_taa_f32,        "post_taa.comp",       "TND_PACKED=0") \
    X(post_taa_packed,     "post_taa.comp",       "TND_PACKED=1") \
    X(post_taau_f32,       "post_taau.comp",      "TND_PACKED=0") \
    X(post_taau_packed,    "post_taau.comp",      "TND_PACKED=1") \
    X(post_histogram,      "post_histogram.comp", "TND_PACKED=0") \
    X(post_exposure,       "post_exposure.comp",  "TND_PACKED=0") \
    X(post_bloom,          "post_bloom.comp",     "TND_PACKED=0") \
    X(post_interleave_f32, "post_interleave.comp", "TND_PACKED=0") \
    X(post_interleave_packed, "post_interleave.comp", "TND_PACKED=1") \
    X(post_tonemap,        "post_tonemap.comp",   "TND_PACKED=0") \
    X(view_compose,        "view_compose.comp",   "") \
    X(dn_lf_f32,           "dn_lf.comp",          "TND_PACKED=0") \
    X(dn_lf_packed,        "dn_lf.comp",          "TND_PACKED=1") \
    X(dn_lf_down_f32,      "dn_lf_down.comp",     "TND_PACKED=0") \
    X(dn_lf_down_packed,   "dn_lf_down.comp",     "TND_PACKED=1") \
    X(pt_rchit,            "pt.rchit",            "") \
    X(pt_alpha_rahit,      "pt_alpha.rahit",      "") \
    X(pt_rmiss,            "pt.rmiss",            "") \
    X(pt_shadow_rmiss,     "pt_shadow.rmiss",     "")
// clang-format on

typedef enum tnd_shader {
#define TND_X(name, file, defines) TND_SHADER_##name,
    TND_SHADER_LIST(TND_X)
#undef TND_X
        TND_SHADER_COUNT
} tnd_shader;

/* The SPIR-V of shader `id` (NULL if out of range); its size in bytes and source file name go to
 * the optional out-parameters. The code is static and lives for the whole program. */
const uint32_t *tnd_spirv_code(tnd_shader id, size_t *bytes, const char **file);
/* Read $TANDEM_SHADER_DIR's overrides again (scripts/compile-shaders.sh writes them): pipelines
 * created after this use them (tandem view's F5). Returns how many shaders are overridden. */
uint32_t tnd_spirv_reload(void);

#endif
