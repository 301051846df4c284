/* Worker threads taking chunks of rows of the host's passes (csi/row_pool.h). */
#include "csi/row_pool.h"

#include <pthread.h>
#include <stdatomic.h>
#include <stdbool.h>
#include <stdlib.h>
#include <unistd.h>

/* The pixels of a chunk: enough that taking one (an atomic increment) is nothing against its
 * work, few enough that a pass of a small image still splits into several. */
#define ROW_POOL_CHUNK_PIXELS 2048

struct csi_row_pool {
    pthread_mutex_t lock;  /* guards everything below but `next` */
    pthread_cond_t go;     /* a pass was posted (or the pool is stopping) */
    pthread_cond_t idle;   /* the last worker in a pass left it */
    pthread_mutex_t owner; /* held by the thread running a pass */
    unsigned long pass;    /* posted passes so far */
    bool open;             /* the posted pass still takes workers */
    bool stop;
    int busy;              /* workers inside the posted pass */
    csi_rows_fn fn;
    void *arg;
    size_t rows, chunk_rows, chunks;
    atomic_size_t next;    /* the next chunk to take */
    int workers;
    pthread_t tid[CSI_ROW_POOL_MAX];
};

/* Takes chunks of the posted pass until none is left. */
static void take_chunks(csi_row_pool *p, csi_rows_fn fn, void *arg)
{
    for (;;) {
        const size_t k = atomic_fetch_add(&p->next, 1);
        if (k >= p->chunks)
            return;
        const size_t r0 = k * p->chunk_rows, r1 = r0 + p->chunk_rows < p->rows ? r0 + p->chunk_rows : p->rows;
        fn(arg, r0, r1);
    }
}

static void *worker(void *v)
{
    csi_row_pool *p = v;
    unsigned long seen = 0;
    pthread_mutex_lock(&p->lock);
    for (;;) {
        while (p->pass == seen && !p->stop)
            pthread_cond_wait(&p->go, &p->lock);
        if (p->stop)
            break;
        seen = p->pass;
        if (!p->open)
            continue; /* woke after the pass was done: nothing of it left */
        p->busy++;
        const csi_rows_fn fn = p->fn;
        void *arg = p->arg;
        pthread_mutex_unlock(&p->lock);
        take_chunks(p, fn, arg);
        pthread_mutex_lock(&p->lock);
        if (--p->busy == 0)
            pthread_cond_signal(&p->idle);
    }
    pthread_mutex_unlock(&p->lock);
    return NULL;
}

int csi_row_pool_threads_for_host(void)
{
    const char *env = getenv("CSI_HOST_THREADS");
    long k = env && *env ? strtol(env, NULL, 10) : sysconf(_SC_NPROCESSORS_ONLN);
    return k < 1 ? 1 : k > CSI_ROW_POOL_MAX ? CSI_ROW_POOL_MAX : (int)k;
}

csi_row_pool *csi_row_pool_new(int threads)
{
    if (threads > CSI_ROW_POOL_MAX)
        threads = CSI_ROW_POOL_MAX;
    if (threads < 2)
        return NULL;
    csi_row_pool *p = calloc(1, sizeof *p);
    if (!p)
        return NULL;
    if (pthread_mutex_init(&p->lock, NULL)) {
        free(p);
        return NULL;
    }
    if (pthread_mutex_init(&p->owner, NULL)) {
        pthread_mutex_destroy(&p->lock);
        free(p);
        return NULL;
    }
    if (pthread_cond_init(&p->go, NULL)) {
        pthread_mutex_destroy(&p->owner);
        pthread_mutex_destroy(&p->lock);
        free(p);
        return NULL;
    }
    if (pthread_cond_init(&p->idle, NULL)) {
        pthread_cond_destroy(&p->go);
        pthread_mutex_destroy(&p->owner);
        pthread_mutex_destroy(&p->lock);
        free(p);
        return NULL;
    }
    atomic_init(&p->next, 0);
    for (int i = 0; i < threads - 1; i++) {
        if (pthread_create(&p->tid[i], NULL, worker, p))
            break;
        p->workers++;
    }
    if (p->workers < threads - 1) {
        csi_row_pool_free(p);
        return NULL;
    }
    return p;
}

void csi_row_pool_free(csi_row_pool *p)
{
    if (!p)
        return;
    pthread_mutex_lock(&p->lock);
    p->stop = true;
    pthread_cond_broadcast(&p->go);
    pthread_mutex_unlock(&p->lock);
    for (int i = 0; i < p->workers; i++)
        pthread_join(p->tid[i], NULL);
    pthread_cond_destroy(&p->idle);
    pthread_cond_destroy(&p->go);
    pthread_mutex_destroy(&p->owner);
    pthread_mutex_destroy(&p->lock);
    free(p);
}

int csi_row_pool_threads(const csi_row_pool *p)
{
    return p ? p->workers + 1 : 1;
}

void csi_row_pool_run(csi_row_pool *p, size_t rows, size_t width, csi_rows_fn fn, void *arg)
{
    if (!rows)
        return;
    size_t chunk_rows = width ? ROW_POOL_CHUNK_PIXELS / width : rows;
    if (chunk_rows < 1)
        chunk_rows = 1;
    /* one chunk, or the pool busy with another thread's pass: all here */
    if (!p || chunk_rows >= rows || pthread_mutex_trylock(&p->owner)) {
        fn(arg, 0, rows);
        return;
    }
    pthread_mutex_lock(&p->lock);
    p->fn = fn, p->arg = arg;
    p->rows = rows, p->chunk_rows = chunk_rows, p->chunks = (rows + chunk_rows - 1) / chunk_rows;
    atomic_store(&p->next, 0);
    p->open = true;
    p->pass++;
    pthread_cond_broadcast(&p->go);
    pthread_mutex_unlock(&p->lock);
    take_chunks(p, fn, arg);
    /* every chunk taken: close the pass to late workers, wait for those inside it */
    pthread_mutex_lock(&p->lock);
    p->open = false;
    while (p->busy)
        pthread_cond_wait(&p->idle, &p->lock);
    pthread_mutex_unlock(&p->lock);
    pthread_mutex_unlock(&p->owner);
}
