// Baselines for MHU21 Fig. 11 (runtime_cl/polygon_baselines.py): splat a per-radius sparse
// kernel (dense polygon, its 5-point Laplacian, or its dx dy difference) into a padded int64
// fixed-point canvas, then the dx dy reconstruction (a row then a column prefix sum).
// Same quantisation and radius table as polygon/splat.cl, so dense and dx dy are bit-identical.
//
// -D constants: NC (channels), BUCKETS (radius lookup buckets per pixel), CB (columns per
// column-prefix work item).
#pragma OPENCL EXTENSION cl_khr_fp64 : enable

// One TILE x TILE tile per work item; one launch runs tiles P apart (P tiles > kernel span), so
// plain adds do not race. Canvas pixel (x + PAD, y + PAD) is image pixel (x, y).
__kernel void scatter(__global const float *image, __global const float *radius,
                      const int W, const int H, __global const float *breaks, const int n_entries,
                      __global const int *bucket, __global const int *term_start,
                      __global const int4 *terms, __global const double *unit,
                      __global ulong *canvas, const int CW, const int PAD,
                      const int TILE, const int P, const int cx, const int cy, const int n_tx)
{
    const int i = get_global_id(0);
    const int x0 = (cx + (i % n_tx) * P) * TILE, y0 = (cy + (i / n_tx) * P) * TILE;
    if (x0 >= W || y0 >= H) return;
    float last_r = -1.0f;
    int e = 0;
    for (int y = y0; y < min(y0 + TILE, H); ++y)
    for (int x = x0; x < min(x0 + TILE, W); ++x) {
        const size_t p = (size_t)y * W + x;
        const float r = radius[p];
        if (r != last_r) { e = find_entry(breaks, n_entries, bucket, r); last_r = r; }
        ulong q[NC];
        if (!quantise(image, unit, p, e, q)) continue;
        for (int t = term_start[e]; t < term_start[e + 1]; ++t) {
            const int4 tm = terms[t];
            __global ulong *dst = canvas + ((size_t)(y + tm.z + PAD) * CW + (x + tm.y + PAD)) * NC;
            for (int c = 0; c < NC; ++c) dst[c] += q[c] * (ulong)(long)tm.w;
        }
    }
}

// In-place prefix sum along each row (one work item per row).
__kernel void row_prefix(__global ulong *canvas, const int CW)
{
    __global ulong *row = canvas + (size_t)get_global_id(0) * CW * NC;
    ulong s[NC];
    for (int c = 0; c < NC; ++c) s[c] = 0;
    for (int x = 0; x < CW; ++x)
        for (int c = 0; c < NC; ++c) { s[c] += row[x * NC + c]; row[x * NC + c] = s[c]; }
}

// Prefix sum down each column (CB columns per work item; `prefix` = 0: no sum, the dense
// canvas), cropped to the image and converted: out = value * factor, or the int64 itself.
__kernel void column_out(__global const ulong *canvas, const int CW, const int PAD, const int W,
                         const int H, const int prefix, __constant double *factor,
                         __global float *out, __global long *fixed_out, const int fixed)
{
    const int x0 = get_global_id(0) * CB;
    if (x0 >= W) return;
    const int n = min(CB, W - x0);
    ulong s[CB * NC];
    for (int i = 0; i < CB * NC; ++i) s[i] = 0;
    for (int y = 0; y < H + PAD; ++y) {
        __global const ulong *row = canvas + ((size_t)y * CW + x0 + PAD) * NC;
        for (int i = 0; i < n * NC; ++i) s[i] = prefix ? s[i] + row[i] : row[i];
        if (y < PAD) continue;
        const size_t o = ((size_t)(y - PAD) * W + x0) * NC;
        for (int i = 0; i < n; ++i)
            for (int c = 0; c < NC; ++c) {
                if (fixed) fixed_out[o + i * NC + c] = (long)s[i * NC + c];
                else out[o + i * NC + c] = (float)((double)(long)s[i * NC + c] * factor[c]);
            }
    }
}
