// scale_polygon's dynamic programme (runtime_cl/polygon_kernel.py) for one radius per work item.
//
// Mirrors the numpy code operation by operation so results are identical, ties included:
//   target = radius * v;  cand = rint(target) + offset (offsets dy-major over [-W, W]^2);
//   cost = (cand - target)^2 summed x then y;  acc/trial sums in the same order;
//   argmin = first index on equal values;  closing argmin over (start, last) row-major.
// FP contraction is off so no product is fused into an add (numpy never fuses).
// Only the transitions numpy allows (next vertex = this one + m * d, m >= 0 integer) are visited:
// for each next candidate j the previous candidates i lie on the ray j - m d inside window k.
//
// -D constants: NV (vertices), WINDOW (half-width of the candidate window), SCRATCH (bytes of
// global scratch per work item; see polygon_scale.py).
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
#pragma OPENCL FP_CONTRACT OFF

#define SIDE (2 * WINDOW + 1)
#define NS (SIDE * SIDE)

inline int floor_div(int a, int b) { int q = a / b; return (q * b != a && ((a < 0) != (b < 0))) ? q - 1 : q; }
inline int ceil_div(int a, int b) { return -floor_div(-a, b); }

// m range [lo, hi] with |p - m * dc - c| <= WINDOW for one coordinate (dc may be 0).
inline void m_range(int p, int dc, int c, int *lo, int *hi) {
    if (dc == 0) {
        if (abs(p - c) > WINDOW) { *lo = 1; *hi = 0; }
        return;
    }
    int a = p - c - WINDOW, b = p - c + WINDOW;  // a <= m dc <= b
    int l = dc > 0 ? ceil_div(a, dc) : ceil_div(b, dc);
    int h = dc > 0 ? floor_div(b, dc) : floor_div(a, dc);
    *lo = max(*lo, l);
    *hi = min(*hi, h);
}

// For window k and next-window candidate j: previous candidates i = i0 + m * step, m in [0, cnt).
// (The m-th point back along the edge direction; visiting order does not matter because ties
// are broken by the smaller index explicitly.)
inline void ray(int px, int py, int2 d, int cx, int cy, int *i0, int *cnt, int *step) {
    int lo = 0, hi = 1 << 30;
    m_range(px, d.x, cx, &lo, &hi);
    m_range(py, d.y, cy, &lo, &hi);
    *cnt = max(hi - lo + 1, 0);
    *i0 = (py - lo * d.y - cy + WINDOW) * SIDE + (px - lo * d.x - cx + WINDOW);
    *step = -(d.y * SIDE + d.x);
}

// One radius per work item; `scratch` holds each work item's tables (SCRATCH bytes apart).
__kernel void scale_dp(__global const double2 *v,       // NV unit vertices
                       __global const int2 *dirs,       // NV edge directions
                       __global const double *radii,    // one radius per work item
                       const int n_radii,
                       __global int2 *out,              // NV chosen vertices per radius
                       __global int *found,             // 1 if some closed path exists
                       __global uchar *scratch)
{
    const int g = get_global_id(0);
    if (g >= n_radii) return;
    __global uchar *base = scratch + (size_t)g * SCRATCH;
    __global double *cost = (__global double *)base;                 // [NV][NS]
    double acc[NS], nxt[NS];
    __global int *ray0 = (__global int *)(cost + NV * NS);            // [NV][NS] first i
    __global int *rayn = ray0 + NV * NS;                              // [NV][NS] count
    __global ushort *back = (__global ushort *)(rayn + NV * NS);      // [NV][NS]
    const double radius = radii[g];
    int rx[NV], ry[NV], steps[NV], path[NV];
    for (int k = 0; k < NV; ++k) {
        const double tx = radius * v[k].x, ty = radius * v[k].y;
        const double fx = rint(tx), fy = rint(ty);
        rx[k] = (int)fx;
        ry[k] = (int)fy;
        for (int s = 0; s < NS; ++s) {
            const double ax = (fx + (double)(s % SIDE - WINDOW)) - tx;
            const double ay = (fy + (double)(s / SIDE - WINDOW)) - ty;
            const double sx = ax * ax, sy = ay * ay;
            cost[k * NS + s] = sx + sy;
        }
    }
    // rays: k >= 1 from window k-1 along dirs[k-1]; k == 0: the closing edge from window NV-1
    for (int k = 0; k < NV; ++k) {
        const int kp = k == 0 ? NV - 1 : k - 1;
        for (int j = 0; j < NS; ++j) {
            int i0, cnt, st;
            ray(rx[k] + j % SIDE - WINDOW, ry[k] + j / SIDE - WINDOW, dirs[kp], rx[kp], ry[kp], &i0, &cnt, &st);
            ray0[k * NS + j] = i0;
            rayn[k * NS + j] = cnt;
            steps[k] = st;
        }
    }
    double best = INFINITY;
    int have = 0;
    for (int start = 0; start < NS; ++start) {
        for (int s = 0; s < NS; ++s) acc[s] = INFINITY;
        acc[start] = cost[start];
        for (int k = 1; k < NV; ++k) {
            for (int j = 0; j < NS; ++j) {
                double mn = INFINITY;
                int arg = 0;
                int i = ray0[k * NS + j];
                const int cnt = rayn[k * NS + j];
                for (int m = 0; m < cnt; ++m, i += steps[k]) {
                    const double t = acc[i];
                    if (t < mn || (t == mn && t < INFINITY && i < arg)) { mn = t; arg = i; }
                }
                back[k * NS + j] = (ushort)arg;
                nxt[j] = mn + cost[k * NS + j];
            }
            for (int s = 0; s < NS; ++s) acc[s] = nxt[s];
        }
        // closing edge: the last vertex lies on the ray start - m * dirs[NV-1]
        double mn = INFINITY;
        int arg = -1;
        int i = ray0[start];
        const int cnt = rayn[start];
        for (int m = 0; m < cnt; ++m, i += steps[0]) {
            const double c = acc[i];
            if (c < mn || (c == mn && c < INFINITY && i < arg)) { mn = c; arg = i; }
        }
        if (mn < best) {
            best = mn;
            have = 1;
            path[NV - 1] = arg;
            for (int k = NV - 1; k > 0; --k) path[k - 1] = back[k * NS + path[k]];
        }
    }
    found[g] = have;
    for (int k = 0; k < NV; ++k) {
        const int s = have ? path[k] : 0;
        out[g * NV + k] = (int2)(rx[k] + s % SIDE - WINDOW, ry[k] + s / SIDE - WINDOW);
    }
}
