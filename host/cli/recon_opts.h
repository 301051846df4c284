/* Reconstruction options shared by csi-render and csi-reconstruct, made from the library's option
 * table (see common_recon.c). */
#ifndef CSI_CLI_RECON_OPTS_H
#define CSI_CLI_RECON_OPTS_H

#include <getopt.h>
#include <stdbool.h>
#include <stdio.h>

#include "csi/csi.h"

/* getopt values of the shared options start here; a program's own values stay below. */
#define CLI_RECON_FIRST 1000

/* own (terminated by a zero entry) followed by the shared options; free() the result. */
struct option *cli_longopts_with_recon(const struct option *own);
/* Whether the command line gave shared option `name` (after the getopt loop). */
bool cli_recon_given(const char *name);
/* The help lines of the shared options. */
void cli_recon_usage(FILE *f);
/* Applies option c if it is a shared one: returns 0 when applied, -1 when c is not a shared
 * option, or an exit code (after printing the error) when its value is bad. */
int cli_recon_option(const char *prog, int c, const char *optarg, csi_options *opt);

/* The same, for a getopt loop's default branch: 0 when applied, otherwise the exit code after
 * printing the error (an unknown option names `arg`, the word getopt stopped at). */
int cli_recon_option_or_fail(const char *prog, int c, const char *optarg, const char *arg,
                             csi_options *opt);

#endif
