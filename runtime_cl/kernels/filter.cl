// LSR18's Filter baseline: gather with the PSF of the output pixel's own cell,
//   out(x) = sum_o psf_x(o) * in(x - o),   in = 0 outside the image.
// One work item per output row (no races; per-row counts without atomics). Needs psf_space.cl.
// Build options (beside psf_space.cl's): CC, DC, OC as in splat.cl.

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
        float acc[OC];
        for (int c = 0; c < OC; ++c) acc[c] = 0.0f;
        // offsets o with x - o inside the image
        const int oy0 = max(-r, y - H + 1), oy1 = min(r, y);
        const int ox0 = max(-r, x - W + 1), ox1 = min(r, x);
        for (int oy = oy0; oy <= oy1; ++oy) {
            __global const float *src = colour + ((long)(y - oy) * W + x) * CC;
            __global const float *p = psf + (long)(oy + r) * side * DC;
            for (int ox = ox0; ox <= ox1; ++ox) {
                for (int c = 0; c < OC; ++c)
                    acc[c] += p[(ox + r) * DC + (DC == 1 ? 0 : c)] * src[-ox * CC + (CC == 1 ? 0 : c)];
            }
        }
        n += (long)max(oy1 - oy0 + 1, 0) * max(ox1 - ox0 + 1, 0);
        for (int c = 0; c < OC; ++c) out[((long)y * W + x) * OC + c] = acc[c];
    }
    counts[y] = n;
}
