/* Built OpenCL programs kept on disk as the driver's own binaries (clGetProgramInfo's
 * CL_PROGRAM_BINARIES), so that a later process loads a program instead of building it.
 * Filled on request only (csi_ctx_cache_programs: `csi-reconstruct --cache-programs`, run by
 * tools/test and tools/demo after a build), because asking PoCL for a binary makes it compile
 * every kernel of the program, far more than one run builds.
 *
 * Why, when PoCL keeps a kernel cache of its own: PoCL finds a program in its cache by a hash of
 * the *preprocessed* source, so every clBuildProgram from source runs Clang's preprocessor over
 * the source, then reads the cached LLVM bitcode back; for csi's few programs that is most of a
 * warm process's fixed cost, more than a small image's whole solve. A binary is found by the
 * source's own hash, without Clang.
 *
 * The key covers everything the binary depends on: the source, the build options, and the
 * platform's and device's names and versions (a new driver is a miss, not a stale binary). A
 * file is written whole under a temporary name and renamed, and carries its length and a
 * checksum: a truncated or corrupt file is a miss (and is replaced), never handed to the driver.
 * Storing a program removes its files of the same device with another source: one binary per
 * program and device is kept.
 * The directory: $CSI_CACHE_DIR/programs, else $XDG_CACHE_HOME/csi/programs, else
 * ~/.cache/csi/programs; none of them, or CSI_PROGRAM_CACHE=0, turns the cache off. Every
 * failure of the cache is a miss: the program is built from source as without it. */
#ifndef CSI_PROGRAM_CACHE_H
#define CSI_PROGRAM_CACHE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include <CL/cl.h>

#include "csi/status.h"

#ifdef __cplusplus
extern "C" {
#endif

/* The program `name` built from `source` with `options` for `device`, loaded from the cache;
 * NULL on a miss (nothing cached, a foreign or damaged file, or the driver refusing it). */
cl_program csi_program_cache_load(cl_context context, cl_device_id device, const char *name, const char *source,
                                  const char *options);

/* Keeps the binary of `program` (built from `source` with `options` for `device`) for later
 * processes. False when it could not (the cache off, a file not written); no file is left
 * behind then. */
bool csi_program_cache_store(cl_program program, cl_device_id device, const char *name, const char *source,
                             const char *options);

/* The checksum a cached file carries of its binary. */
uint64_t csi_program_cache_checksum(const void *data, size_t n);

/* The cache's directory into out; false when the cache is off. */
bool csi_program_cache_dir(char *out, size_t len);

/* The same, for a caller that needs the cache on: CSI_ERR_IO saying why it is off. */
csi_status csi_program_cache_require_dir(char *out, size_t len);

/* Makes a cache directory and its parents (mkdir -p); what exists already is kept, a failure
 * shows up when the cache's file is written. */
void csi_cache_mkdirs(const char *path);

#ifdef __cplusplus
}
#endif

#endif
