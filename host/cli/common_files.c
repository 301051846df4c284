/* A run's outputs (csi_outset): the set, whose temporary files a signal removes too, and an
 * output written by one of the library's writers (the writer names the temporary file it was
 * given, the message names the output the user asked for). */
#include <pthread.h>
#include <signal.h>
#include <stdio.h>
#include <string.h>

#include "common.h"

/* The run's outputs, for the signal handler: an interrupted run leaves nothing either. */
static csi_outset *volatile signal_set;
/* The thread that makes the outputs' temporary files. */
static pthread_t signal_thread;

static void on_signal(int sig)
{
    /* A signal sent to the process lands on any thread that does not block it (PoCL's and
     * Embree's workers too); a cleanup there would run while the writing thread goes on making
     * files. So it is handed to the writing thread, which stops while its handler runs and holds
     * signals back while it makes a temporary file (csi_outfile_hold_signals). */
    if (!pthread_equal(pthread_self(), signal_thread)) {
        pthread_kill(signal_thread, sig);
        return;
    }
    csi_outset_signal_cleanup(signal_set);
    signal(sig, SIG_DFL);
    raise(sig);
}

csi_status cli_outset_new(csi_outset **set)
{
    CSI_TRY(csi_outset_create(set));
    signal_set = *set;
    signal_thread = pthread_self();
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal;
    sigemptyset(&sa.sa_mask);
    const int sigs[] = {SIGINT, SIGTERM, SIGHUP};
    for (size_t i = 0; i < sizeof sigs / sizeof sigs[0]; i++)
        sigaction(sigs[i], &sa, NULL);
    return CSI_OK;
}

void cli_outset_free(csi_outset *set)
{
    if (signal_set == set)
        signal_set = NULL;
    csi_outset_free(set);
}

csi_status cli_named(csi_status s, const char *tmp, const char *path)
{
    const char *m = cli_last_error();
    if (s != CSI_OK && tmp && path && !strncmp(m, tmp, strlen(tmp))) {
        char rest[1024];
        snprintf(rest, sizeof rest, "%s", m + strlen(tmp));
        return cli_fail(s, "%s%s", path, rest);
    }
    return s;
}

csi_status cli_write_dump(csi_outset *set, const char *path, const csi_dump *d)
{
    const char *tmp;
    CSI_TRY(csi_outset_tmp(set, path, &tmp));
    return cli_named(csi_dump_write(tmp, d), tmp, path);
}

csi_status cli_write_stats(csi_outset *set, const char *path, csi_json *j)
{
    const char *tmp;
    CSI_TRY(csi_outset_tmp(set, path, &tmp));
    return cli_named(csi_json_write(j, tmp), tmp, path);
}
