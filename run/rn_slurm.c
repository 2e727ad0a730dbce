/* run/rn_slurm.c: what the Slurm jobs the run layer writes share (the sweep's, the rank's): shell
 * words, a tandem command line, each job script's preamble, the tandem binary's path. */
#include "run/rn_internal.h"

#include <unistd.h>

void rn_sh_word(FILE *f, const char *s)
{
    fputc('\'', f);
    for (; *s; s++)
        if (*s == '\'')
            fputs("'\\''", f);
        else
            fputc(*s, f);
    fputc('\'', f);
}

void rn_sh_command(FILE *f, const char *tandem, const rn_args *a, const char *extra)
{
    rn_sh_word(f, tandem);
    for (int k = 0; k < a->n; k++) {
        fputc(' ', f);
        rn_sh_word(f, a->v[k]);
    }
    if (extra)
        fprintf(f, " %s", extra);
}

void rn_sh_preamble(FILE *f, const char *by, const char *what, const char *name, int array)
{
    fprintf(f, "#!/bin/bash\n# %s (written by %s --emit slurm; submit.sh submits it)\n", what,
            by);
    fprintf(f, "#SBATCH --job-name=tandem-%s\n", name);
    if (array > 0)
        fprintf(f, "#SBATCH --array=0-%d\n", array - 1);
    fprintf(f, "set -u\n"
               "gpu=${CUDA_VISIBLE_DEVICES:-}\n"
               "[ -n \"${TANDEM_DEVICE:-}\" ] || [ -z \"$gpu\" ] || export TANDEM_DEVICE=${gpu%%%%,*}\n"
               "threads=${SLURM_CPUS_PER_TASK:-0}\n");
}

tnd_result rn_tandem_binary(char *out, size_t cap)
{
    ssize_t l = readlink("/proc/self/exe", out, cap - 1);
    if (l <= 0)
        return tnd_fail(TND_ERR_IO, "cannot find the tandem binary (/proc/self/exe)");
    out[l] = 0;
    return TND_OK;
}
