// LSR18's Filter baseline: gather with the PSF of the output pixel's own cell,
//   out(x) = sum_o psf_x(o) * in(x - o),   in = 0 outside the image.
// One work item per output row (no races; per-row counts without atomics). Needs psf/psf_space.cl.
// Build options (beside psf/psf_space.cl's): CC, DC, OC as in spreadlets/splat.cl; RGB(A) is gathered as float4.
// ROTATE = 1 (needs spreadlets/rotate.cl first): the PSF is turned by the output pixel's angle, the same
// turned PSF as spreadlets/splat.cl's (spreadlets/rotate.cl), so a PSF that is the same everywhere gives the Splat
// baseline's image.
#ifndef ROTATE
#define ROTATE 0
#endif

// pix_t, DB_VALUE, COLOUR: prelude/pixels.cl

#if ROTATE

// out(x, y) with the PSF of radius r at psf turned by cs (spreadlets/rotate.cl; the energy scale comes
// from the whole turned PSF, inside the image or not); n counts the turned PSF's pixels (in
// its support) whose input pixel lies inside the image.
inline pix_t gather_rotated(__global const float *colour, const int H, const int W, const int x,
                            const int y, const int r, __global const float *psf, const float4 stored,
                            const float4 box, const float2 cs, long *n) {
    const int reach = turned_reach(r, cs);
    pix_t acc = (pix_t)0.0f;
    float4 turned = (float4)0.0f, v;
    int lo, hi;
    for (int dy = -reach; dy <= reach; ++dy) {
        turned_cols(cs, box, reach, dy, &lo, &hi);
        for (int dx = lo; dx <= hi; ++dx) {
            if (!turned_value(psf, r, cs, dx, dy, &v)) continue;
            turned += v;
            const int sx = x - dx, sy = y - dy;
            if (sx < 0 || sx >= W || sy < 0 || sy >= H) continue;
            acc += TO_PIX(v) * COLOUR(colour, (long)sy * W + sx);
            ++*n;
        }
    }
    return is_quarter_turn(cs) ? acc : acc * TO_PIX(energy_scale(stored, turned));
}
#endif

__kernel void filter_gather(__global const float *colour,      // (H, W, CC)
                            __global const float *coords,      // (H, W, PSF_NS)
                            __global const float *angle,       // (H, W) radians (read if ROTATE)
                            __global const PSF_REAL *psf_thr,
                            __global const int *psf_bucket,
                            __global const int *dense_r,       // (n,)
                            __global const long *dense_off,    // (n+1,)
                            __global const float *dense_v,     // (sum, DC)
                            __global const float *dense_sum,   // (n, DC) sums (read if ROTATE)
                            __global const int4 *dense_box,    // (n,) non-zero box (read if ROTATE)
                            __global float *out,               // (H, W, OC)
                            __global long *counts,             // (H,) PSF pixels gathered per row
                            const int H, const int W) {
    const int y = get_global_id(0);
    if (y >= H) return;
    long n = 0;
    for (int x = 0; x < W; ++x) {
        const int cell = psf_cell(coords + ((long)y * W + x) * PSF_NS, psf_thr, psf_bucket);
        const int r = dense_r[cell];
        __global const float *psf = dense_v + dense_off[cell] * DC;
#if ROTATE
        const pix_t acc = gather_rotated(colour, H, W, x, y, r, psf, stored_sum(dense_sum, cell),
                                         support_box(dense_box, cell), rotation_cs(angle[(long)y * W + x]), &n);
#else
        const int side = 2 * r + 1;
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
#endif
#if OC == 1
        out[(long)y * W + x] = acc;
#elif OC == 3
        vstore3(acc.xyz, (long)y * W + x, out);
#else
        vstore4(acc, (long)y * W + x, out);
#endif
    }
    counts[y] = n;
}
