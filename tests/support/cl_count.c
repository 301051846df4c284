/* The device buffers the process holds, counted at OpenCL's entry points (cl_count.h). */
#define _GNU_SOURCE
#include "cl_count.h"

#include <dlfcn.h>

#include <CL/cl.h>

#define TAB_MAX 4096
static struct {
    cl_mem m;
    size_t size;
} tab[TAB_MAX];
static int ntab, created;
static uint64_t live, peak;

uint64_t test_cl_live(void) { return live; }
uint64_t test_cl_peak(void) { return peak; }
void test_cl_reset_peak(void) { peak = live; }
int test_cl_created(void) { return created; }

cl_mem clCreateBuffer(cl_context context, cl_mem_flags flags, size_t size, void *host_ptr, cl_int *err)
{
    typedef cl_mem (*fn_t)(cl_context, cl_mem_flags, size_t, void *, cl_int *);
    static fn_t real;
    if (!real)
        real = (fn_t)dlsym(RTLD_NEXT, "clCreateBuffer");
    cl_int e = CL_SUCCESS;
    cl_mem m = real(context, flags, size, host_ptr, &e);
    if (err)
        *err = e;
    if (e == CL_SUCCESS && m && ntab < TAB_MAX) {
        tab[ntab].m = m;
        tab[ntab++].size = size;
        live += size;
        created++;
        if (live > peak)
            peak = live;
    }
    return m;
}

cl_int clReleaseMemObject(cl_mem m)
{
    typedef cl_int (*fn_t)(cl_mem);
    static fn_t real;
    if (!real)
        real = (fn_t)dlsym(RTLD_NEXT, "clReleaseMemObject");
    for (int i = 0; i < ntab; i++)
        if (tab[i].m == m) {
            live -= tab[i].size;
            tab[i] = tab[--ntab];
            break;
        }
    return real(m);
}
