// Exact (race-free, deterministic) splatting with private row bands. Needs psf_space.cl first.
//
// Work item b owns input rows [b*band_rows, (b+1)*band_rows) and a private band buffer that
// covers the canvas rows those pixels can reach: band_rows + 2*PAD rows of buf_w pixels, with
// GROUPS planes per pixel (group 0: Laplacian or dense, group 1: fast-track dense). It zeroes
// its band and adds into it sequentially, so plain += is exact. merge_bands then sums the
// overlapping bands of each canvas pixel in a fixed order (bit-reproducible results).
// Canvas coordinates: input pixel (x, y) sits at (x + PAD, y + PAD).
//
// A band pixel is one float (OC = 1) or a float4 whose 4th lane stays 0 (OC = 3): one vector
// add per spreadlet measured 419 vs 309 M spreadlets/s for three scalar adds on PoCL.
//
// Build options (beside psf_space.cl's):
//   CC, DC, OC   colour channels, database channels, output channels = max(CC, DC) (1 or 3)
//   PAD          canvas padding: largest spreadlet offset or dense radius + 1
//   DENSE_ALL    1: every pixel splats its dense PSF (LSR18's Splat baseline) into group 0;
//                0: spreadlets into group 0, fast-tracked cells dense into group 1 (if HAS_FAST)
//   HAS_FAST     the database has fast-tracked cells (0 saves the second group)
//   GROUPS       planes groups per band: 1 + (HAS_FAST && !DENSE_ALL)

#define DENSE_GROUP (DENSE_ALL ? 0 : 1)

#if OC == 1
typedef float pix_t;
#define DB_VALUE(v, j) ((v)[(j)])
#define COLOUR(c, i) ((c)[(i)])
#define IS_ZERO(v) ((v) == 0.0f)
#else
typedef float4 pix_t;
#define IS_ZERO(v) all((v) == (float4)0.0f)  // vector compares give -1 per true lane
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

inline void splat_dense(__global pix_t *dst, const int buf_w, const pix_t col,
                        const int r, __global const float *dv) {
    // dst: band position of the PSF's top-left corner (offset (-r, -r))
    const int side = 2 * r + 1;
    for (int oy = 0; oy < side; ++oy) {
        __global pix_t *row = dst + (long)oy * buf_w;
        const int j0 = oy * side;
        for (int ox = 0; ox < side; ++ox) row[ox] += DB_VALUE(dv, j0 + ox) * col;
    }
}

__kernel void splat_bands(__global const float *colour,      // (H, W, CC)
                          __global const float *coords,      // (H, W, PSF_NS)
                          __global const PSF_REAL *psf_thr,
                          __global const int *psf_bucket,
                          __global const long *C,            // (n+1,)
                          __global const short2 *P,          // (m,) (dx, dy)
                          __global const float *V,           // (m, DC)
                          __global const uchar *fast,        // (n,)
                          __global const int *dense_r,       // (n,)
                          __global const long *dense_off,    // (n+1,)
                          __global const float *dense_v,     // (sum, DC)
                          __global pix_t *bands,             // (nbands, GROUPS, rows, buf_w)
                          __global long *counts,             // (nbands, 2): spreadlets, dense px
                          const int H, const int W, const int band_rows, const int buf_w) {
    const int b = get_global_id(0);
    const int rows = band_rows + 2 * PAD;
    const long group_stride = (long)rows * buf_w;
    __global pix_t *band = bands + (long)b * GROUPS * group_stride;
    for (long i = 0; i < GROUPS * group_stride; ++i) band[i] = (pix_t)0.0f;

    const int y0 = b * band_rows;
    const int y1 = min(y0 + band_rows, H);
    long n_spreadlets = 0, n_dense = 0;
    for (int y = y0; y < y1; ++y) {
        for (int x = 0; x < W; ++x) {
            const long i = (long)y * W + x;
            const pix_t col = COLOUR(colour, i);
            if (IS_ZERO(col)) continue;  // empty pixels splat nothing (LSR18: culled early)
            const int cell = psf_cell(coords + i * PSF_NS, psf_thr, psf_bucket);
            const long centre = (long)(y - y0 + PAD) * buf_w + (x + PAD);
#if DENSE_ALL || HAS_FAST
            if (DENSE_ALL || fast[cell]) {
                const int r = dense_r[cell];
                splat_dense(band + DENSE_GROUP * group_stride + centre - ((long)r * buf_w + r),
                            buf_w, col, r, dense_v + dense_off[cell] * DC);
                n_dense += (long)(2 * r + 1) * (2 * r + 1);
                continue;
            }
#endif
            __global pix_t *lap = band + centre;
            const long j1 = C[cell + 1];
            n_spreadlets += j1 - C[cell];
            for (long j = C[cell]; j < j1; ++j) {
                const short2 p = P[j];
                lap[(long)p.y * buf_w + p.x] += DB_VALUE(V, j) * col;
            }
        }
    }
    counts[2 * b] = n_spreadlets;
    counts[2 * b + 1] = n_dense;
}

// canvas (GROUPS, canvas_h, buf_w, OC): each canvas row is the sum of the band rows covering
// it, bands in increasing order. One work item per canvas row; the fixed local size (1)
// spares PoCL a re-compile per image size.
__kernel void merge_bands(__global const pix_t *bands, __global float *canvas,
                          const int nbands, const int band_rows, const int buf_w, const int canvas_h) {
    const int cy = get_global_id(0);
    if (cy >= canvas_h) return;
    const int rows = band_rows + 2 * PAD;
    const int b_hi = min(cy / band_rows, nbands - 1);
    const int b_lo = cy < rows ? 0 : (cy - rows) / band_rows + 1;  // first b with b*band_rows + rows > cy
    for (int g = 0; g < GROUPS; ++g) {
        __global float *dst = canvas + ((long)g * canvas_h + cy) * buf_w * OC;
        for (int x = 0; x < buf_w; ++x) {
            pix_t acc = (pix_t)0.0f;
            for (int b = b_lo; b <= b_hi; ++b)
                acc += bands[(((long)b * GROUPS + g) * rows + (cy - b * band_rows)) * buf_w + x];
#if OC == 1
            dst[x] = acc;
#else
            vstore3(acc.xyz, x, dst);
#endif
        }
    }
}
