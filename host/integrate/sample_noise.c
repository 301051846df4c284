/* How noisy a volume's samples are, from the variances a renderer gives with them
 * (csi_samples.variance): Alg. 2's tau follows it (motion.c; issue 12, docs/bench/animation.md
 * session 31).
 *
 * Per channel, sqrt(mean of the samples' variances) / mean |value|: the noise of one sample
 * relative to the level tau is scaled by. It is a ratio, so samples scaled by a power of two (as
 * csi_recon scales them) give the same figure, and a tile scales it by its own level. */
#include <math.h>

#include "csi/reconstruct.h"

void csi_recon_sample_noise(const float *values, const float *variance, size_t n, uint32_t channels,
                            double noise[4])
{
    for (uint32_t c = 0; c < 4; c++)
        noise[c] = 0;
    if (!variance || n == 0)
        return;
    for (uint32_t c = 0; c < channels && c < 4; c++) {
        double var = 0, level = 0; /* in sample order: the same bits on every run */
        for (size_t i = 0; i < n; i++) {
            var += variance[i * channels + c];
            level += fabs((double)values[i * channels + c]);
        }
        noise[c] = level > 0 ? sqrt(var / (double)n) / (level / (double)n) : 0;
    }
}
