/* Where a reconstruction's device time goes, kernel by kernel (issue 13; docs/bench/cost.md).
 *
 * An LD_PRELOAD library for any csi program: every clEnqueueNDRangeKernel is bracketed by
 * clFinish, and the wall time and the process's CPU time (all threads: PoCL's CPU device runs
 * kernels on its own threads) of the launch are added up per kernel name. At exit it writes one
 * line per kernel, "name<TAB>launches<TAB>wall s<TAB>CPU s", to $CSI_KERNEL_PROFILE (or
 * stderr). The extra clFinish serialises nothing that was not serial already (csi's queues are
 * in order) but removes the overlap of the host's enqueueing with the device's work, so the sum
 * exceeds an unprofiled run's solve time slightly; on a shared machine the CPU column is the
 * one to compare.
 *
 *   CSI_KERNEL_PROFILE=prof.tsv LD_PRELOAD=build/libcsi-preload-kernel-profile.so \
 *       build/csi-reconstruct demo.csid -o out.exr -q
 *   sort -t$'\t' -k4 -gr prof.tsv
 */
#define _GNU_SOURCE
#include <dlfcn.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <time.h>

#define CL_TARGET_OPENCL_VERSION 120
#include <CL/cl.h>

enum { MAX_KERNELS = 512, NAME_LEN = 128 };

typedef struct {
    char name[NAME_LEN];
    long launches;
    double wall, cpu;
} entry;

static entry table[MAX_KERNELS];
static int n_entries;
static pthread_mutex_t lock = PTHREAD_MUTEX_INITIALIZER;

static double wall_now(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

static double cpu_now(void)
{
    struct rusage r;
    getrusage(RUSAGE_SELF, &r);
    return (double)(r.ru_utime.tv_sec + r.ru_stime.tv_sec) + 1e-6 * (double)(r.ru_utime.tv_usec + r.ru_stime.tv_usec);
}

typedef cl_int (*enqueue_fn)(cl_command_queue, cl_kernel, cl_uint, const size_t *, const size_t *, const size_t *,
                             cl_uint, const cl_event *, cl_event *);

CL_API_ENTRY cl_int CL_API_CALL clEnqueueNDRangeKernel(cl_command_queue q, cl_kernel k, cl_uint dims,
                                                       const size_t *offset, const size_t *global,
                                                       const size_t *local, cl_uint n_wait,
                                                       const cl_event *wait, cl_event *ev)
{
    static enqueue_fn real;
    if (!real)
        real = (enqueue_fn)dlsym(RTLD_NEXT, "clEnqueueNDRangeKernel");
    char name[NAME_LEN] = {0};
    clGetKernelInfo(k, CL_KERNEL_FUNCTION_NAME, sizeof name - 1, name, NULL);
    clFinish(q); /* the previous launches' time is theirs */
    const double w0 = wall_now(), c0 = cpu_now();
    const cl_int st = real(q, k, dims, offset, global, local, n_wait, wait, ev);
    clFinish(q);
    const double w = wall_now() - w0, c = cpu_now() - c0;
    pthread_mutex_lock(&lock);
    int i = 0;
    while (i < n_entries && strcmp(table[i].name, name) != 0)
        i++;
    if (i == n_entries && n_entries < MAX_KERNELS)
        memcpy(table[n_entries++].name, name, sizeof name);
    if (i < n_entries) {
        table[i].launches++;
        table[i].wall += w;
        table[i].cpu += c;
    }
    pthread_mutex_unlock(&lock);
    return st;
}

__attribute__((destructor)) static void write_profile(void)
{
    const char *path = getenv("CSI_KERNEL_PROFILE");
    FILE *f = path && *path ? fopen(path, "w") : stderr;
    if (!f)
        f = stderr;
    for (int i = 0; i < n_entries; i++)
        fprintf(f, "%s\t%ld\t%.6f\t%.6f\n", table[i].name, table[i].launches, table[i].wall, table[i].cpu);
    if (f != stderr)
        fclose(f);
}
