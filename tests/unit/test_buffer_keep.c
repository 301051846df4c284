/* Large device buffers kept for reuse between problems (csi/buffer_keep.h), checked against an
 * independent count of what the process holds: every clCreateBuffer and clReleaseMemObject
 * (cl_count.h).
 *
 * Claims: outside a keep scope a released buffer is released; inside one, a released buffer of
 * CSI_BUFFER_KEEP_MIN bytes or more stays allocated but not live (csi_device_bytes_live), and the
 * next csi_buffer of the same size and flags takes that very buffer back (no new allocation, the
 * bytes it held still there) while other flags or smaller sizes get new ones; a new buffer that
 * would take what the process holds over the peak of live bytes releases kept ones first, so the
 * held bytes never exceed the counted peak; scopes nest, and the last end releases every kept
 * buffer. */
#include <stdlib.h>
#include <string.h>

#include "csi/buffer_keep.h"
#include "csi/runtime.h"
#include "cl_count.h"
#include "testlib.h"

#define MIB ((size_t)1 << 20)

int main(void)
{
    csi_ctx *ctx = test_ctx();
    csi_finish(ctx);
    const uint64_t held0 = test_cl_live(), live0 = csi_device_bytes_live();
    const size_t big = CSI_BUFFER_KEEP_MIN, other = CSI_BUFFER_KEEP_MIN + 8 * MIB;
    cl_mem a = NULL, b = NULL, c = NULL;

    /* Outside a scope: released. */
    REQUIRE_OK(csi_buffer(ctx, big, CL_MEM_READ_WRITE, "test", &a));
    csi_buffer_release(&a);
    CHECK(test_cl_live() == held0, "outside a scope a released buffer is released (%llu bytes held)",
          (unsigned long long)(test_cl_live() - held0));

    /* Inside: kept, not live, taken back with its bytes. */
    csi_buffer_keep_begin(ctx);
    csi_device_bytes_reset_peak();
    REQUIRE_OK(csi_buffer(ctx, big, CL_MEM_READ_WRITE, "test", &a));
    const cl_mem first = a;
    const uint32_t pattern[4] = {0x3f800000u, 0xdeadbeefu, 7u, 0x7f7fffffu};
    REQUIRE_OK(csi_write(ctx, a, big - sizeof pattern, sizeof pattern, pattern));
    csi_buffer_release(&a);
    CHECK(test_cl_live() == held0 + big && csi_device_bytes_live() == live0, "kept: %llu bytes held, %llu live",
          (unsigned long long)(test_cl_live() - held0), (unsigned long long)(csi_device_bytes_live() - live0));
    const int made = test_cl_created();
    REQUIRE_OK(csi_buffer(ctx, big, CL_MEM_READ_WRITE, "test", &a));
    CHECK(a == first && test_cl_created() == made, "the same size and flags take the kept buffer back");
    uint32_t back[4] = {0, 0, 0, 0};
    REQUIRE_OK(csi_read(ctx, a, big - sizeof back, sizeof back, back));
    CHECK(!memcmp(back, pattern, sizeof back), "a buffer taken back holds what was left in it");
    CHECK(csi_device_bytes_live() == live0 + big && test_cl_live() == held0 + big, "taken back: live again, nothing new held");

    /* Other flags and small sizes: new buffers; a small one is not kept. */
    csi_buffer_release(&a);
    REQUIRE_OK(csi_buffer(ctx, big, CL_MEM_READ_ONLY, "test", &b));
    CHECK(b != first && test_cl_created() == made + 1, "other flags: a new buffer");
    csi_buffer_release(&b);
    REQUIRE_OK(csi_buffer(ctx, MIB, CL_MEM_READ_WRITE, "test", &c));
    csi_buffer_release(&c);
    CHECK(test_cl_live() <= held0 + 2 * big, "a buffer under CSI_BUFFER_KEEP_MIN is released (%llu bytes held)",
          (unsigned long long)(test_cl_live() - held0));

    /* The bound: a new size beyond the peak (here: none live, 2 x big kept) releases kept
     * buffers first, and what the process holds is then within the counted peak. */
    csi_device_bytes_reset_peak();
    REQUIRE_OK(csi_buffer(ctx, other, CL_MEM_READ_WRITE, "test", &c));
    CHECK(test_cl_live() == held0 + other, "kept buffers released for a new size over the peak (%llu bytes held, %llu live)",
          (unsigned long long)(test_cl_live() - held0), (unsigned long long)(csi_device_bytes_live() - live0));
    CHECK(test_cl_live() - held0 <= csi_device_bytes_peak() - live0, "held bytes %llu within the counted peak %llu",
          (unsigned long long)(test_cl_live() - held0), (unsigned long long)(csi_device_bytes_peak() - live0));

    /* Nesting, and the last end releases. */
    csi_buffer_keep_begin(ctx);
    csi_buffer_release(&c);
    csi_buffer_keep_end(ctx);
    CHECK(test_cl_live() == held0 + other, "an inner end keeps what the outer scope keeps");
    csi_buffer_keep_end(ctx);
    CHECK(test_cl_live() == held0 && csi_device_bytes_live() == live0, "the last end releases every kept buffer (%llu held)",
          (unsigned long long)(test_cl_live() - held0));
    return test_done();
}
