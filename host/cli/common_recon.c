/* The reconstruction options csi-render and csi-reconstruct share, made from the library's
 * option table: the getopt rows, the help text (with the library's defaults) and the parsing
 * are all generated, so a new option needs no edit here. */
#include <getopt.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common.h"
#include "recon_opts.h"

/* Which shared options the command line gave (a program may default one by its own rule). */
static bool given[128];

struct option *cli_longopts_with_recon(const struct option *own)
{
    size_t n_own = 0, n_rec = csi_option_count();
    while (own[n_own].name)
        n_own++;
    struct option *all = calloc(n_own + n_rec + 1, sizeof *all);
    if (!all || n_rec > sizeof given / sizeof given[0]) {
        free(all);
        return NULL;
    }
    memcpy(all, own, n_own * sizeof *all);
    size_t at = n_own;
    for (size_t i = 0; i < n_rec; i++) {
        csi_option_info info;
        if (csi_option_describe(i, &info) != CSI_OK || !info.program)
            continue;
        all[at++] = (struct option){info.name, info.kind == CSI_OPTION_FLAG ? no_argument : required_argument,
                                    NULL, CLI_RECON_FIRST + (int)i};
    }
    return all; /* the last entry stays zero */
}

/* Writes `text` from column `col` on, wrapped before column 96 with continuation lines indented
 * to column 28. Returns the column after the last word. */
static int put_wrapped(FILE *f, const char *text, int col)
{
    const int indent = 28, width = 96;
    const char *p = text;
    while (*p) {
        const char *e = p;
        while (*e && *e != ' ')
            e++;
        const int len = (int)(e - p);
        if (col > indent && col + 1 + len > width) {
            fprintf(f, "\n%*s", indent, "");
            col = indent;
        } else if (col > indent) {
            fputc(' ', f);
            col++;
        }
        fprintf(f, "%.*s", len, p);
        col += len;
        p = *e ? e + 1 : e;
    }
    return col;
}

void cli_recon_usage(FILE *f)
{
    fputs("method (the library's defaults; auto: chosen from the problem, see the statistics; 0 is auto\n"
          "too for a number whose default is auto, not for a size):\n", f);
    for (size_t i = 0; i < csi_option_count(); i++) {
        csi_option_info o;
        if (csi_option_describe(i, &o) != CSI_OK || !o.program)
            continue;
        char head[64];
        snprintf(head, sizeof head, "      --%s%s%s", o.name, o.metavar ? " " : "", o.metavar ? o.metavar : "");
        fputs(head, f);
        int col = (int)strlen(head);
        if (col < 27) {
            fprintf(f, "%*s", 28 - col, "");
            col = 28;
        } else {
            fputc('\n', f);
            fprintf(f, "%28s", "");
            col = 28;
        }
        /* sized by the text: a fixed buffer once cut --correct's help off mid-word */
        const char *dflt = o.kind == CSI_OPTION_FLAG ? NULL : o.auto_rule ? o.auto_rule : o.def;
        const size_t len = strlen(o.help) + (dflt ? strlen(dflt) + 32 : 0) + 1;
        char *text = malloc(len);
        if (!text) {
            fputs(o.help, f);
        } else {
            if (!dflt)
                snprintf(text, len, "%s", o.help);
            else
                snprintf(text, len, o.auto_rule ? "%s [default: auto = %s]" : "%s [default: %s]", o.help, dflt);
            put_wrapped(f, text, col);
            free(text);
        }
        fputc('\n', f);
    }
}

int cli_recon_option(const char *prog, int c, const char *optarg, csi_options *opt)
{
    csi_option_info info;
    if (c < CLI_RECON_FIRST || csi_option_describe((size_t)(c - CLI_RECON_FIRST), &info) != CSI_OK)
        return -1;
    const char *value = info.kind == CSI_OPTION_FLAG ? "on" : optarg;
    if (csi_options_set(opt, info.name, value) != CSI_OK)
        return cli_error(prog, CSI_ERR_ARG, "--%s", cli_last_error()); /* "name: 'v' is not ..." */
    given[c - CLI_RECON_FIRST] = true;
    return 0;
}

bool cli_recon_given(const char *name)
{
    for (size_t i = 0; i < csi_option_count() && i < sizeof given / sizeof given[0]; i++) {
        csi_option_info info;
        if (csi_option_describe(i, &info) == CSI_OK && !strcmp(info.name, name))
            return given[i];
    }
    return false;
}

int cli_recon_option_or_fail(const char *prog, int c, const char *optarg, const char *arg,
                             csi_options *opt)
{
    int rc = cli_recon_option(prog, c, optarg, opt);
    if (rc < 0)
        return cli_error(prog, CSI_ERR_ARG, "unknown or incomplete option '%s' (see --help)", arg);
    return rc;
}
