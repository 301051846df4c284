/* What a convex region's samples make certain of a pixel's cells (csi/convex_band.h). */
#include "csi/convex_band.h"

#include <math.h>
#include <stdlib.h>

static const double PI = 3.14159265358979323846;

static int cmp_point(const void *a, const void *b)
{
    const csi_point2 *p = a, *q = b;
    return p->x < q->x ? -1 : p->x > q->x ? 1 : p->y < q->y ? -1 : p->y > q->y ? 1 : 0;
}

static double cross(csi_point2 o, csi_point2 a, csi_point2 b)
{
    return (a.x - o.x) * (b.y - o.y) - (a.y - o.y) * (b.x - o.x);
}

/* The convex hull of p (sorted in place), counter-clockwise without collinear points; its size
 * (fewer than 3 points: the distinct ones). */
static size_t convex_hull(csi_point2 *p, size_t n, csi_point2 *h)
{
    qsort(p, n, sizeof *p, cmp_point);
    size_t u = 0; /* distinct points */
    for (size_t i = 0; i < n; i++)
        if (!u || p[i].x != p[u - 1].x || p[i].y != p[u - 1].y)
            p[u++] = p[i];
    if (u < 3) {
        for (size_t i = 0; i < u; i++)
            h[i] = p[i];
        return u;
    }
    size_t k = 0;
    for (size_t i = 0; i < u; i++) { /* the lower chain */
        while (k >= 2 && cross(h[k - 2], h[k - 1], p[i]) <= 0)
            k--;
        h[k++] = p[i];
    }
    for (size_t i = u - 1, lower = k + 1; i-- > 0;) { /* the upper chain */
        while (k >= lower && cross(h[k - 2], h[k - 1], p[i]) <= 0)
            k--;
        h[k++] = p[i];
    }
    return k - 1; /* the first point closed the chain */
}

/* Inside or on the edges of the counter-clockwise hull h (at least 3 points: a hull of fewer holds
 * no area). */
static bool in_hull(const csi_point2 *h, size_t k, csi_point2 q)
{
    if (k < 3)
        return false;
    for (size_t i = 0; i < k; i++)
        if (cross(h[i], h[(i + 1) % k], q) < -1e-12)
            return false;
    return true;
}

/* An angle in [-pi, pi). */
static double wrap(double a)
{
    return a - 2.0 * PI * floor((a + PI) / (2.0 * PI));
}

bool csi_convex_band(csi_point2 *in, size_t n_in, const csi_point2 *out, size_t n_out, const csi_point2 *cells,
                     size_t n_cells, csi_point2 *hull, double *span, size_t *sure_in, size_t *sure_out)
{
    *sure_in = *sure_out = 0;
    if (!n_in)
        return false;
    const size_t k = convex_hull(in, n_in, hull);
    for (size_t j = 0; j < n_out; j++)
        if (in_hull(hull, k, out[j]))
            return false;
    /* each point of `out`: the directions from it to the hull's vertices, about their mean */
    for (size_t j = 0; j < n_out; j++) {
        const csi_point2 d = out[j];
        double mx = 0, my = 0, lo = INFINITY, hi = -INFINITY;
        for (size_t i = 0; i < k; i++)
            mx += hull[i].x - d.x, my += hull[i].y - d.y;
        const double ref = atan2(my, mx);
        for (size_t i = 0; i < k; i++) {
            const double a = wrap(atan2(hull[i].y - d.y, hull[i].x - d.x) - ref);
            lo = fmin(lo, a), hi = fmax(hi, a);
        }
        span[3 * j] = ref, span[3 * j + 1] = lo, span[3 * j + 2] = hi;
    }
    for (size_t c = 0; c < n_cells; c++) {
        if (in_hull(hull, k, cells[c])) {
            (*sure_in)++;
            continue;
        }
        for (size_t j = 0; j < n_out; j++) {
            const double ref = span[3 * j], lo = span[3 * j + 1], hi = span[3 * j + 2];
            if (hi - lo >= PI)
                continue;
            const double a = wrap(atan2(cells[c].y - out[j].y, cells[c].x - out[j].x) + PI - ref);
            if (a >= lo && a <= hi) {
                (*sure_out)++;
                break;
            }
        }
    }
    return true;
}
