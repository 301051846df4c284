/* The reconstruction's progress line: phase, the solver's step, and an estimate of the time
 * left from the channels' solves already done (csi_recon_options.progress names the phases
 * "setup", "solve c/C", "integrate c/C", in a tiled run each after "tile t/T "). A run is T x C
 * such solves, one after another: the solve of channel c in tile t is the ((t - 1) C + c)-th. The
 * cross-validated choice's folds also say "solve 1/1" after a tile's channels; their index is
 * never past the current one, so they are not counted, and their time goes into the average. */
#include <stdio.h>
#include <string.h>

#include "common.h"

void cli_recon_progress_init(cli_recon_progress *p, cli_progress *bar)
{
    memset(p, 0, sizeof *p);
    p->bar = bar;
}

double cli_recon_progress_eta(const cli_recon_progress *p, double now)
{
    if (p->done == 0 || p->units == 0)
        return -1.0;
    /* Channels cost about the same (one operator, the same sample count), and so do tiles (one
     * window size): the mean so far, what happens between the solves included. */
    double per = (p->t_current - p->t_first) / p->done;
    double left = per * (p->units - p->done) - (now - p->t_current);
    return left > 0 ? left : 0;
}

void cli_recon_progress_update(cli_recon_progress *p, const char *phase, int iter, double res)
{
    unsigned t = 1, nt = 1, c = 0, nc = 0;
    int at = 0;
    const double now = cli_now();
    const char *solve = phase;
    if (sscanf(phase, "tile %u/%u %n", &t, &nt, &at) == 2 && at > 0)
        solve = phase + at;
    if (sscanf(solve, "solve %u/%u", &c, &nc) == 2 && c >= 1 && c <= nc && t >= 1 && t <= nt) {
        const unsigned u = (t - 1) * nc + c;
        if (u > p->unit) {
            if (p->unit == 0)
                p->t_first = now;
            p->done = u - 1; /* every earlier solve is integrated */
            p->unit = u;
            p->units = nt * nc;
            p->t_current = now;
        }
    }
    char detail[128] = "", eta[32] = "";
    double left = cli_recon_progress_eta(p, now);
    if (left >= 0)
        snprintf(eta, sizeof eta, "  eta %.0fs", left + 0.5);
    if (res >= 0)
        snprintf(detail, sizeof detail, "step %d  residual %.2e%s", iter, res, eta);
    else if (iter > 0)
        snprintf(detail, sizeof detail, "step %d%s", iter, eta);
    else
        snprintf(detail, sizeof detail, "%s", eta[0] ? eta + 2 : "");
    cli_progress_update(p->bar, phase, -1, detail);
}

bool cli_recon_progress_fn(void *user, const csi_progress *p)
{
    if (user)
        cli_recon_progress_update(user, p->phase, p->iteration, p->residual);
    return true;
}
