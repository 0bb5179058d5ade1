// LSR18's Filter baseline: gather with the PSF of the output pixel's own cell,
//   out(x) = sum_o psf_x(o) * in(x - o),   in = 0 outside the image.
// One work item per output row (no races; per-row counts without atomics). Needs psf_space.cl.
// Build options (beside psf_space.cl's): CC, DC, OC as in splat.cl; RGB is gathered as float4.

#if OC == 1
typedef float pix_t;
#define DB_VALUE(v, j) ((v)[(j)])
#define COLOUR(c, i) ((c)[(i)])
#else
typedef float4 pix_t;
#if DC == 1
#define DB_VALUE(v, j) ((float4)((v)[(j)]))
#else
#define DB_VALUE(v, j) ((float4)((v)[3 * (j)], (v)[3 * (j) + 1], (v)[3 * (j) + 2], 0.0f))
#endif
#if CC == 1
#define COLOUR(c, i) ((float4)((c)[(i)], (c)[(i)], (c)[(i)], 0.0f))
#else
#define COLOUR(c, i) ((float4)((c)[3 * (i)], (c)[3 * (i) + 1], (c)[3 * (i) + 2], 0.0f))
#endif
#endif

__kernel void filter_gather(__global const float *colour,      // (H, W, CC)
                            __global const float *coords,      // (H, W, PSF_NS)
                            __global const PSF_REAL *psf_thr,
                            __global const int *psf_bucket,
                            __global const int *dense_r,       // (n,)
                            __global const long *dense_off,    // (n+1,)
                            __global const float *dense_v,     // (sum, DC)
                            __global float *out,               // (H, W, OC)
                            __global long *counts,             // (H,) PSF pixels gathered per row
                            const int H, const int W) {
    const int y = get_global_id(0);
    if (y >= H) return;
    long n = 0;
    for (int x = 0; x < W; ++x) {
        const int cell = psf_cell(coords + ((long)y * W + x) * PSF_NS, psf_thr, psf_bucket);
        const int r = dense_r[cell];
        const int side = 2 * r + 1;
        __global const float *psf = dense_v + dense_off[cell] * DC;
        pix_t acc = (pix_t)0.0f;
        // offsets o with x - o inside the image
        const int oy0 = max(-r, y - H + 1), oy1 = min(r, y);
        const int ox0 = max(-r, x - W + 1), ox1 = min(r, x);
        for (int oy = oy0; oy <= oy1; ++oy) {
            const long row = (long)(y - oy) * W + x;  // input pixel index at ox = 0
            const int j = (oy + r) * side + r;        // PSF index at ox = 0
            for (int ox = ox0; ox <= ox1; ++ox) acc += DB_VALUE(psf, j + ox) * COLOUR(colour, row - ox);
        }
        n += (long)max(oy1 - oy0 + 1, 0) * max(ox1 - ox0 + 1, 0);
#if OC == 1
        out[(long)y * W + x] = acc;
#else
        vstore3(acc.xyz, (long)y * W + x, out);
#endif
    }
    counts[y] = n;
}
