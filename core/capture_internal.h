/* core/capture_internal.h: what capture.c (Tandem's own captures) and capture_map.c (other
 * renderers' EXRs through a mapping) share. */
#ifndef TND_CAPTURE_INTERNAL_H
#define TND_CAPTURE_INTERNAL_H

#include "core/core.h"

/* Problems found while validating a file, reported together. */
typedef struct cap_problems {
    char text[3500];
    int count;
} cap_problems;
void cap_problem_add(cap_problems *p, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

/* The camera of Tandem's header attributes (tandem.view, .proj, .prevView, .prevProj, .frame,
 * .jitter); has_camera when all four matrices are there. */
void cap_read_tandem_camera(const tnd_exr_file *x, tnd_frame *f);

#endif
