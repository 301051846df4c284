/* Writing a reconstruction's outputs (EXR with metadata, PNG preview, frames, stats JSON):
 * shared by csi-reconstruct and csi-render so both write the same files the same way. */
#ifndef CSI_CLI_OUTPUTS_H
#define CSI_CLI_OUTPUTS_H

#include "csi/dump.h"
#include "common.h"
#include "csi/reconstruct.h"
#include "csi/stats.h"

typedef struct cli_outputs {
    const char *exr, *png, *frames_dir, *stats;
} cli_outputs;

/* States every output of the run in `set` before any work (csi_outset: directories exist and
 * are writable, no output is an input or another output), nframes frames' EXR and PNG files in
 * the frames folder included. */
csi_status cli_outputs_stage(const cli_outputs *o, csi_outset *set, uint32_t nframes);


/* The solver's figures and every option as used, as JSON members. */
void cli_stats_recon(csi_json *j, const csi_recon_result *r);

/* Wall-clock seconds of the phases the program runs itself (the library times the rest). */
typedef struct cli_phase_times {
    double read, device, write; /* reading the dump, making the OpenCL context, the outputs */
} cli_phase_times;
/* "phases" {read, device, programs, setup, solve: {channel: s}, integrate: {channel: s}, write}
 * (programs is part of setup: building the kernels, a cost of the first run on a machine or of
 * a cold cache); "fixed_s" = read + device + setup, what a run costs before its first solver
 * step; "per_sample_us" = (solve + integrate) / samples; "cpu_setup_s", "cpu_work_s" and
 * "cpu_per_sample_us": the same in process CPU time (all threads). */
void cli_stats_phases(csi_json *j, const cli_phase_times *t, const csi_recon_result *r);

/* Writes the image (and frames) with attributes describing the run to their temporary files in
 * set; csi_outset_commit puts them in place. */
csi_status cli_write_images(const cli_outputs *o, csi_outset *set, const csi_recon_result *r, const char *method);

#endif
