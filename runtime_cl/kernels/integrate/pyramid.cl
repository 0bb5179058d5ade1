// Convolution pyramid (Farbman et al. 2011) for the free-space Poisson solve; the operator is
// runtime_cl/integrate/pyramid_model.py's. Images are (rows, cols, C) float32, C interleaved.
// -D C=channels, R1 / R2 = radius of the separable taps h1 / h2, RG = radius of the 2-D g,
// PAD = zero samples added on each side of a level before it is filtered and halved.
// Each kernel takes a fast path without bounds checks when its whole stencil is inside the
// arrays (most work items); `guard` is a constant at every call, so inlining drops the checks.

// a[y][x][c] - m of a level of size (h, w), zero outside (m: level 0's canvas mean, else 0)
inline float at(__global const float *a, int h, int w, int y, int x, int c, float m, int guard)
{
    if (guard && (y < 0 || y >= h || x < 0 || x >= w))
        return 0.0f;
    return a[(y * w + x) * C + c] - m;
}

// per row, the sum of each channel (the canvas mean: the exact solve ignores it)
__kernel void row_sums(__global const float *a, int h, int w, __global float *sums)
{
    int y = get_global_id(0);
    if (y >= h) return;
    float s[C];
    for (int c = 0; c < C; ++c) s[c] = 0.0f;
    for (int x = 0; x < w; ++x)
        for (int c = 0; c < C; ++c) s[c] += a[(y * w + x) * C + c];
    for (int c = 0; c < C; ++c) sums[y * C + c] = s[c];
}

// mean[c] = (sum of the h row sums) / (h w); one work item per channel
__kernel void finish_mean(__global const float *sums, int h, int w, __global float *mean)
{
    int c = get_global_id(0);
    float s = 0.0f;
    for (int y = 0; y < h; ++y) s += sums[y * C + c];
    mean[c] = s / ((float)h * (float)w);
}

inline void rows_at(__global const float *a, int h, int w, __global const float *mean,
                    __global float *tmp, int nw, __constant float *h1, int y, int i, int guard)
{
    int x0 = 2 * i - R1 - PAD;
    for (int c = 0; c < C; ++c) {
        float s = 0.0f;
        for (int k = 0; k <= 2 * R1; ++k)
            s += h1[k] * at(a, h, w, y, x0 + k, c, mean[c], guard);
        tmp[(y * nw + i) * C + c] = s;
    }
}

// analysis, across: tmp[y][i] = sum_k h1[k] a[y][2i + k - R1 - PAD]   (tmp is h x nw)
__kernel void analysis_rows(__global const float *a, int h, int w, __global const float *mean,
                            __global float *tmp, int nw, __constant float *h1)
{
    int i = get_global_id(0), y = get_global_id(1);
    if (i >= nw || y >= h) return;
    int x0 = 2 * i - R1 - PAD;
    if (x0 >= 0 && x0 + 2 * R1 < w)
        rows_at(a, h, w, mean, tmp, nw, h1, y, i, 0);
    else
        rows_at(a, h, w, mean, tmp, nw, h1, y, i, 1);
}

inline void cols_at(__global const float *tmp, int h, int nw, __global float *next,
                    __constant float *h1, int j, int i, int guard)
{
    int y0 = 2 * j - R1 - PAD;
    for (int c = 0; c < C; ++c) {
        float s = 0.0f;
        for (int k = 0; k <= 2 * R1; ++k)
            s += h1[k] * at(tmp, h, nw, y0 + k, i, c, 0.0f, guard);
        next[(j * nw + i) * C + c] = s;
    }
}

// analysis, down: next[j][i] = sum_k h1[k] tmp[2j + k - R1 - PAD][i]   (next is nh x nw)
__kernel void analysis_cols(__global const float *tmp, int h, int nw, __global float *next, int nh,
                            __constant float *h1)
{
    int i = get_global_id(0), j = get_global_id(1);
    if (i >= nw || j >= nh) return;
    int y0 = 2 * j - R1 - PAD;
    if (y0 >= 0 && y0 + 2 * R1 < h)
        cols_at(tmp, h, nw, next, h1, j, i, 0);
    else
        cols_at(tmp, h, nw, next, h1, j, i, 1);
}

// s[y][x][c] = (h2 * up(coarse))[y + PAD][x + PAD] + (g * a)[y][x]; no coarse term at the top
inline float synth_at(__global const float *a, int h, int w, float m,
                      __global const float *coarse, int ch, int cw, int has_coarse,
                      __constant float *h2, __constant float *g, int y, int x, int c, int guard)
{
    float s = 0.0f;
    for (int dy = -RG; dy <= RG; ++dy)
        for (int dx = -RG; dx <= RG; ++dx)
            s += g[(dy + RG) * (2 * RG + 1) + dx + RG] * at(a, h, w, y + dy, x + dx, c, m, guard);
    if (has_coarse) {
        int uy = y + PAD - R2, ux = x + PAD - R2;
        // only even up-sampled positions hold coarse samples: start the taps on the first one
        for (int ky = (uy & 1); ky <= 2 * R2; ky += 2) {
            float row = 0.0f;
            int cy = (uy + ky) >> 1;
            for (int kx = (ux & 1); kx <= 2 * R2; kx += 2)
                row += h2[kx] * at(coarse, ch, cw, cy, (ux + kx) >> 1, c, 0.0f, guard);
            s += h2[ky] * row;
        }
    }
    return s;
}

// whether synth_at(y, x) reads only samples inside both arrays
inline int synth_inside(int h, int w, int ch, int cw, int y, int x)
{
    return y >= RG && y + RG < h && x >= RG && x + RG < w
           && y + PAD - R2 >= 0 && ((y + PAD + R2) >> 1) < ch
           && x + PAD - R2 >= 0 && ((x + PAD + R2) >> 1) < cw;
}

// one level of the synthesis, minus offset[c] (level 0: its border ring's mean; else zeros)
__kernel void synthesis(__global const float *a, int h, int w, __global const float *mean,
                        __global const float *coarse, int ch, int cw, int has_coarse,
                        __constant float *h2, __constant float *g, __global const float *offset,
                        __global float *out)
{
    int x = get_global_id(0), y = get_global_id(1);
    if (x >= w || y >= h) return;
    if (synth_inside(h, w, ch, cw, y, x)) {
        for (int c = 0; c < C; ++c)
            out[(y * w + x) * C + c] = synth_at(a, h, w, mean[c], coarse, ch, cw, has_coarse, h2, g,
                                                y, x, c, 0) - offset[c];
    } else {
        for (int c = 0; c < C; ++c)
            out[(y * w + x) * C + c] = synth_at(a, h, w, mean[c], coarse, ch, cw, has_coarse, h2, g,
                                                y, x, c, 1) - offset[c];
    }
}

// offset[c] = mean of level 0's synthesis over the canvas's border ring (one work item per channel)
__kernel void ring_mean(__global const float *a, int h, int w, __global const float *mean,
                        __global const float *coarse, int ch, int cw,
                        __constant float *h2, __constant float *g, __global float *offset)
{
    int c = get_global_id(0);
    float m = mean[c], s = 0.0f;
    for (int x = 0; x < w; ++x)
        s += synth_at(a, h, w, m, coarse, ch, cw, 1, h2, g, 0, x, c, 1)
             + synth_at(a, h, w, m, coarse, ch, cw, 1, h2, g, h - 1, x, c, 1);
    for (int y = 1; y < h - 1; ++y)
        s += synth_at(a, h, w, m, coarse, ch, cw, 1, h2, g, y, 0, c, 1)
             + synth_at(a, h, w, m, coarse, ch, cw, 1, h2, g, y, w - 1, c, 1);
    offset[c] = s / (float)(2 * w + 2 * (h - 2));
}
