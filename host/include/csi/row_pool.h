/* A pool of worker threads for the host's passes over an image's rows (row_pool.c).
 *
 * The host's per-pixel passes (the blend, csi/reconstruct.h's CSI_CORRECT_BLEND, the fit's trust,
 * csi/peak_noise.h, csi/empty_pixels.h) ran on the calling thread while the OpenCL device's own
 * threads waited for them. A pass whose result at a pixel depends only on its inputs, not on
 * the other pixels' results of the same pass, gives the same bits however its rows are split,
 * so a pass is cut into chunks of whole rows that the calling thread and the workers take in
 * turn, and the calling thread returns when all are done (a barrier). The workers are started
 * once, with the pool, and sleep between passes; chunks rather than one band a thread, so that
 * a worker that does not get a core (the machine busy) delays a pass by at most one chunk: the
 * calling thread takes what the workers have not.
 *
 * Nothing is global: a pool belongs to its owner (one per OpenCL context, csi/runtime.h). A pass
 * given to a pool that is running another (two threads on one context) runs on its calling
 * thread alone. Progress callbacks stay on the calling thread: a pass's function must not call
 * them. */
#ifndef CSI_ROW_POOL_H
#define CSI_ROW_POOL_H

#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef struct csi_row_pool csi_row_pool;

/* A pass over rows [row0, row1) of an image. */
typedef void (*csi_rows_fn)(void *arg, size_t row0, size_t row1);

/* The most threads a pool runs passes on, the calling thread included: the device's threads share
 * the host's cores, and the passes read memory faster than a few cores can use it. */
#define CSI_ROW_POOL_MAX 4

/* The threads a pool takes on this host: its online cores, or the environment's CSI_HOST_THREADS
 * where set (1: the calling thread alone, for a comparison), 1 to CSI_ROW_POOL_MAX. */
int csi_row_pool_threads_for_host(void);

/* A pool running passes on `threads` threads, the calling thread one of them (threads - 1
 * workers, clamped to 1..CSI_ROW_POOL_MAX). NULL when a worker cannot be started (and for a
 * single thread): csi_row_pool_run on NULL runs on the calling thread. */
csi_row_pool *csi_row_pool_new(int threads);
/* Stops and joins the workers. NULL is ignored. */
void csi_row_pool_free(csi_row_pool *pool);
/* The threads the pool's passes run on (1 for NULL). */
int csi_row_pool_threads(const csi_row_pool *pool);

/* fn over rows [0, rows) of an image `width` pixels wide, in chunks of consecutive rows (of about
 * the same pixel count whatever the width), all done on return. pool NULL: one call over all
 * rows on the calling thread. */
void csi_row_pool_run(csi_row_pool *pool, size_t rows, size_t width, csi_rows_fn fn, void *arg);

#ifdef __cplusplus
}
#endif

#endif
