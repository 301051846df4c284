/* Large device buffers kept for reuse between the problems a context runs in sequence
 * (csi/buffer_keep.h). */
#include "csi/buffer_keep.h"

#include <pthread.h>

#define KEEP_CONTEXTS 16 /* contexts keeping at once */
#define KEEP_BUFFERS 64  /* buffers kept at once, all contexts */

static pthread_mutex_t keep_mu = PTHREAD_MUTEX_INITIALIZER;
static struct {
    cl_context context;
    int depth; /* csi_buffer_keep_begin calls not yet ended */
} scopes[KEEP_CONTEXTS];
static struct {
    cl_context context;
    cl_mem m;
    size_t bytes;
    cl_mem_flags flags;
} kept[KEEP_BUFFERS]; /* oldest first */
static int nkept;
static uint64_t kept_bytes;

static int scope_of(cl_context c)
{
    for (int i = 0; i < KEEP_CONTEXTS; i++)
        if (scopes[i].depth > 0 && scopes[i].context == c)
            return i;
    return -1;
}

/* Releases kept buffer i; under the lock. */
static void drop(int i)
{
    kept_bytes -= kept[i].bytes;
    clReleaseMemObject(kept[i].m);
    for (int j = i + 1; j < nkept; j++)
        kept[j - 1] = kept[j];
    nkept--;
}

void csi_buffer_keep_begin(csi_ctx *ctx)
{
    const cl_context c = csi_ctx_context(ctx);
    pthread_mutex_lock(&keep_mu);
    int i = scope_of(c);
    for (int j = 0; i < 0 && j < KEEP_CONTEXTS; j++)
        if (scopes[j].depth == 0) {
            scopes[j].context = c;
            i = j;
        }
    if (i >= 0) /* more contexts than slots: that one keeps nothing */
        scopes[i].depth++;
    pthread_mutex_unlock(&keep_mu);
}

void csi_buffer_keep_end(csi_ctx *ctx)
{
    const cl_context c = csi_ctx_context(ctx);
    pthread_mutex_lock(&keep_mu);
    const int i = scope_of(c);
    if (i >= 0 && --scopes[i].depth == 0)
        for (int j = nkept - 1; j >= 0; j--)
            if (kept[j].context == c)
                drop(j);
    pthread_mutex_unlock(&keep_mu);
}

bool csi_buffer_keep_take(cl_context context, size_t bytes, cl_mem_flags flags, cl_mem *out)
{
    if (bytes < CSI_BUFFER_KEEP_MIN)
        return false;
    pthread_mutex_lock(&keep_mu);
    bool found = false;
    for (int i = 0; i < nkept && !found; i++)
        if (kept[i].context == context && kept[i].bytes == bytes && kept[i].flags == flags) {
            *out = kept[i].m;
            kept_bytes -= bytes;
            for (int j = i + 1; j < nkept; j++)
                kept[j - 1] = kept[j];
            nkept--;
            found = true;
        }
    /* a new buffer: the kept ones may take the process over the peak it reached without them */
    const uint64_t peak = csi_device_bytes_peak(), live = csi_device_bytes_live();
    while (!found && nkept > 0 && live + kept_bytes + bytes > peak)
        drop(0);
    pthread_mutex_unlock(&keep_mu);
    return found;
}

bool csi_buffer_keep_put(cl_mem m, size_t bytes)
{
    if (bytes < CSI_BUFFER_KEEP_MIN)
        return false;
    cl_context c = NULL;
    cl_mem_flags flags = 0;
    cl_mem parent = NULL;
    void *host = NULL;
    if (clGetMemObjectInfo(m, CL_MEM_CONTEXT, sizeof c, &c, NULL) != CL_SUCCESS ||
        clGetMemObjectInfo(m, CL_MEM_FLAGS, sizeof flags, &flags, NULL) != CL_SUCCESS ||
        clGetMemObjectInfo(m, CL_MEM_ASSOCIATED_MEMOBJECT, sizeof parent, &parent, NULL) != CL_SUCCESS ||
        clGetMemObjectInfo(m, CL_MEM_HOST_PTR, sizeof host, &host, NULL) != CL_SUCCESS || parent || host)
        return false;
    pthread_mutex_lock(&keep_mu);
    const bool keep = scope_of(c) >= 0 && nkept < KEEP_BUFFERS;
    if (keep) {
        kept[nkept].context = c;
        kept[nkept].m = m;
        kept[nkept].bytes = bytes;
        kept[nkept].flags = flags;
        nkept++;
        kept_bytes += bytes;
    }
    pthread_mutex_unlock(&keep_mu);
    return keep;
}
