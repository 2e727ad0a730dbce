/* pipeline/pl_denoisers.h: the registered denoisers, in order, one line each (the first is the
 * commands' default; `tandem view`'s keys 1, 2, 3 ... follow this order). Each names the ops table
 * its adapter (pipeline/pl_dn_NAME.c) defines; docs/extending.md. No include guard: pl_denoiser.c
 * includes it twice with PL_DENOISER defined. */
PL_DENOISER(pl_asvgf_ops)
PL_DENOISER(pl_svgf_ops)
PL_DENOISER(pl_off_ops)
PL_DENOISER(pl_recurrent_ops)
