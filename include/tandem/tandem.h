/* tandem.h: libtandem's public interface, the pipeline and everything it uses: the contract and
 * its captures, the Vulkan context (core/core.h), the back-end (denoise/denoise.h), the post
 * chain (composite/composite.h), the front-end interface and the frame (pipeline/pipeline.h),
 * the metrics and reports (eval/eval.h), and the run layer over them (run/run.h: render,
 * references, evaluation, sweeps, datasets as functions). Prefixes: tnd_ (core), dn_, cmp_, pl_,
 * ev_, rn_. docs/library.md shows a program that renders a sequence, makes its matched
 * reference and evaluates it, and one that denoises a capture; pkg-config --cflags --libs
 * tandem, or find_package(Tandem) in CMake. */
#ifndef TANDEM_H
#define TANDEM_H

#include "pipeline/pipeline.h"
#include "run/run.h"

#define TANDEM_VERSION_MAJOR 0
#define TANDEM_VERSION_MINOR 1

#endif
