/* Writing a reconstruction's outputs (EXR with metadata, PNG preview, frames): shared by
 * csi-reconstruct, csi-render and csi-merge so all write the same files the same way. */
#ifndef CSI_CLI_OUTPUTS_H
#define CSI_CLI_OUTPUTS_H

#include "common.h"

typedef struct cli_outputs {
    const char *exr, *png, *frames_dir, *stats;
} cli_outputs;

/* States every output of the run in `set` before any work (csi_outset: directories exist and
 * are writable, no output is an input or another output), nframes frames' EXR and PNG files in
 * the frames folder included. */
csi_status cli_outputs_stage(const cli_outputs *o, csi_outset *set, uint32_t nframes);

/* Writes the image (and frames) with the result's attributes (csi_result_attributes; "csi:method"
 * replaced by `method` when not NULL, which says more: "..., poisson positions") to their
 * temporary files in set; csi_outset_commit puts them in place. Progress ("write", by images and
 * each EXR's scanlines) goes to bar unless it is NULL; the bar is ended after. */
csi_status cli_write_images(const cli_outputs *o, csi_outset *set, const csi_result *r, const char *method,
                            cli_progress *bar);

/* The method as the programs name it: the result's (csi_result_info), with the estimator's name
 * in place of the solver's for the baselines. */
const char *cli_solver_or_estimator(const csi_result *r, char *buf, size_t len);

/* Warns (unless quiet) about every channel whose solve did not converge; false if there was one
 * (a fit that is not identifiable is reported in the statistics, not warned about). */
bool cli_warn_unconverged(const char *prog, const csi_result *r, bool quiet);

#endif
