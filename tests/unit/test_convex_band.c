/* csi_convex_band (csi/convex_band.h) against brute force by Caratheodory's theorem: a point of the
 * plane lies in the convex hull of a set exactly when it lies in a triangle of three of its points
 * (or on a segment of two, which random points never are). So a cell is sure to be in the region
 * when some triangle of the region's samples holds it, and sure to be out when some point of the
 * other side lies in a triangle of the region's samples and the cell: no hull is built.
 *
 *   1. Random convex regions (discs and thin rotated strips: a lamp, a strip light), the region's
 *      samples inside, the others' outside, query points anywhere: the counts equal the brute
 *      force's exactly, over 40 draws.
 *   2. The other side's sample inside the region's hull (a region not convex there): false.
 *   3. Fewer than three distinct samples of the region: no cell inside; the cells behind a pair
 *      still sure to be out. */
#include <math.h>
#include <stdbool.h>
#include <string.h>

#include "csi/convex_band.h"
#include "testlib.h"

enum { N_IN_MAX = 24, N_OUT_MAX = 48, N_CELLS = 64 };

static double orient(csi_point2 a, csi_point2 b, csi_point2 c)
{
    return (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
}

static bool in_triangle(csi_point2 a, csi_point2 b, csi_point2 c, csi_point2 q)
{
    const double d1 = orient(a, b, q), d2 = orient(b, c, q), d3 = orient(c, a, q);
    return (d1 >= 0 && d2 >= 0 && d3 >= 0) || (d1 <= 0 && d2 <= 0 && d3 <= 0);
}

/* q in the hull of p[0..n) by some triangle of three of them. */
static bool in_hull_brute(const csi_point2 *p, size_t n, csi_point2 q)
{
    for (size_t i = 0; i < n; i++)
        for (size_t j = i + 1; j < n; j++)
            for (size_t k = j + 1; k < n; k++)
                if (orient(p[i], p[j], p[k]) != 0 && in_triangle(p[i], p[j], p[k], q))
                    return true;
    return false;
}

static void brute(const csi_point2 *in, size_t n_in, const csi_point2 *out, size_t n_out, const csi_point2 *cells,
                  size_t *sure_in, size_t *sure_out)
{
    csi_point2 with[N_IN_MAX + 1];
    memcpy(with, in, n_in * sizeof *in);
    *sure_in = *sure_out = 0;
    for (size_t c = 0; c < N_CELLS; c++) {
        if (in_hull_brute(in, n_in, cells[c])) {
            (*sure_in)++;
            continue;
        }
        with[n_in] = cells[c];
        for (size_t j = 0; j < n_out; j++)
            if (in_hull_brute(with, n_in + 1, out[j])) {
                (*sure_out)++;
                break;
            }
    }
}

/* Is q in the region: a disc of radius 1 about (cx, cy), or a strip 0.6 wide and 4 long turned by a. */
static bool region(int strip, double cx, double cy, double a, csi_point2 q)
{
    const double dx = q.x - cx, dy = q.y - cy;
    if (!strip)
        return dx * dx + dy * dy < 1.0;
    const double u = dx * cos(a) + dy * sin(a), v = -dx * sin(a) + dy * cos(a);
    return fabs(u) < 2.0 && fabs(v) < 0.3;
}

int main(void)
{
    test_rng r;
    test_rng_seed(&r, 51);
    csi_point2 in[N_IN_MAX], out[N_OUT_MAX], cells[N_CELLS], hull[2 * N_IN_MAX], copy[N_IN_MAX];
    double span[3 * N_OUT_MAX];
    size_t moved_in = 0, moved_out = 0;

    /* 1. convex regions: the counts equal the brute force's */
    for (int draw = 0; draw < 40; draw++) {
        const int strip = draw % 2;
        const double cx = test_rng_uniform(&r) - 0.5, cy = test_rng_uniform(&r) - 0.5,
                     a = 3.14159265358979 * test_rng_uniform(&r);
        size_t n_in = 0, n_out = 0;
        while (n_in < N_IN_MAX || n_out < N_OUT_MAX) {
            const csi_point2 q = {6.0 * test_rng_uniform(&r) - 3.0, 6.0 * test_rng_uniform(&r) - 3.0};
            if (region(strip, cx, cy, a, q)) {
                if (n_in < N_IN_MAX)
                    in[n_in++] = q;
            } else if (n_out < N_OUT_MAX) {
                out[n_out++] = q;
            }
        }
        for (size_t c = 0; c < N_CELLS; c++)
            cells[c] = (csi_point2){cx + 3.0 * test_rng_uniform(&r) - 1.5, cy + 3.0 * test_rng_uniform(&r) - 1.5};
        size_t want_in, want_out, got_in, got_out;
        brute(in, n_in, out, n_out, cells, &want_in, &want_out);
        memcpy(copy, in, sizeof in);
        const bool ok = csi_convex_band(copy, n_in, out, n_out, cells, N_CELLS, hull, span, &got_in, &got_out);
        CHECK(ok && got_in == want_in && got_out == want_out,
              "draw %d (%s): convex %d, inside %zu (brute force %zu), out %zu (brute force %zu)", draw,
              strip ? "strip" : "disc", ok, got_in, want_in, got_out, want_out);
        moved_in += got_in, moved_out += got_out;
    }
    printf("40 draws: %zu cells sure inside, %zu sure outside, of %d\n", moved_in, moved_out, 40 * N_CELLS);
    CHECK(moved_in > 0 && moved_out > 0, "the draws say nothing: %zu inside, %zu outside", moved_in, moved_out);

    /* 2. a point of the other side inside the region's hull: false */
    {
        csi_point2 sq[4] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}}, o[1] = {{0.1, 0.2}};
        size_t a, b;
        CHECK(!csi_convex_band(sq, 4, o, 1, cells, N_CELLS, hull, span, &a, &b), "a point inside the hull: convex");
    }
    /* 3. two points: no cell inside; the cells beyond the pair from a point of the other side are out */
    {
        csi_point2 two[2] = {{-1, 0}, {1, 0}}, o[1] = {{0, 1}};
        const csi_point2 q[3] = {{0, 2}, {0, -2}, {3, -0.1}};
        size_t a, b;
        CHECK(csi_convex_band(two, 2, o, 1, q, 3, hull, span, &a, &b) && a == 0 && b == 1,
              "two points: %zu inside, %zu out (want 0, 1: only (0, 2) puts (0, 1) in the hull)", a, b);
    }
    return test_done();
}
