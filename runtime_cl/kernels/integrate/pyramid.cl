// Convolution pyramid (Farbman et al. 2011) for the free-space Poisson solve; the operator is
// runtime_cl/integrate/pyramid_model.py's. Images are (rows, cols, C) float32, C interleaved, so
// a row is w C floats and a shift by dx pixels is a shift by C dx floats for every channel: the
// row-wise kernels work on runs of VW floats of a row (any C), the rest per pixel.
// -D C=channels, R1 / R2 = radius of the separable taps h1 / h2, RG = radius of the 2-D g,
// PAD = zero samples added on each side of a level before it is filtered and halved.
// VW = floats per work item of the row-wise kernels (4, 8 or 16), RB = rows per synthesis item. Buffers hold 16 spare floats at
// their end, so a vector load at a row's last floats stays inside.
// h2p is h2 with one 0 appended: the zero-insertion taps of a parity p are h2p[2t + p], t <= R2.

// VW (4, 8 or 16) floats at a[i], any alignment: a vector type aligned like a float, so the
// compiler emits one unaligned vector load or store (PoCL's vloadn/vstoren are library calls it
// never inlines, and VW scalar loads are not merged)
typedef float floatv __attribute__((ext_vector_type(VW), aligned(4)));

inline floatv loadv(__global const float *a, int i) { return *(__global const floatv *)(a + i); }

inline void to_array(floatv v, float *t) { *(floatv *)t = v; }

// Per-channel constants (the canvas mean, the ring's offset) travel as lane tables of C x VW
// floats, tab[c0 VW + k] = value[(c0 + k) % C]: the VW floats from float f of a row start with
// channel f % C, so their values are the VW floats at tab + (f % C) VW, and value[c] = tab[c VW].
inline floatv lanes(__global const float *tab, int f) { return loadv(tab, (f % C) * VW); }

// store floats i .. i + VW - 1 of a row of n floats starting at `row`, only those inside the row
inline void storev(__global float *out, int row, int i, int n, const float *t)
{
    __global float *o = out + row + i;
    if (i + VW <= n) {
        *(__global floatv *)o = *(const floatv *)t;
    } else {
        for (int k = 0; i + k < n; ++k) o[k] = t[k];
    }
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

// the lane table of the canvas mean, (sum of the h row sums) / (h w) per channel; one work item
__kernel void finish_mean(__global const float *sums, int h, int w, __global float *mean_tab)
{
    float m[C];
    for (int c = 0; c < C; ++c) {
        float s = 0.0f;
        for (int y = 0; y < h; ++y) s += sums[y * C + c];
        m[c] = s / ((float)h * (float)w);
    }
    for (int c0 = 0; c0 < C; ++c0)
        for (int k = 0; k < VW; ++k) mean_tab[c0 * VW + k] = m[(c0 + k) % C];
}

// analysis, down the columns: t[j][.] = sum_k h1[k] (a[2j + k - R1 - PAD][.] - mean), rows outside
// the level being zero; t is nh x w. One work item per 4 floats of a row.
__kernel void down_v(__global const float *a, int h, int w, __global const float *mean_tab,
                     __global float *t, int nh, __constant float *h1)
{
    int f = VW * get_global_id(0), j = get_global_id(1), n = w * C;
    if (f >= n || j >= nh) return;
    floatv m = lanes(mean_tab, f), acc = (floatv)(0.0f);
    int y0 = 2 * j - R1 - PAD;
    for (int k = 0; k <= 2 * R1; ++k) {
        int y = y0 + k;
        if (y >= 0 && y < h)
            acc += h1[k] * (loadv(a, y * n + f) - m);
    }
    float r[VW];
    to_array(acc, r);
    storev(t, j * n, f, n, r);
}

// analysis, across the rows: next[j][i] = sum_k h1[k] t[j][2i + k - R1 - PAD] (next is nh x nw).
// One work item per VW floats of the filtered row at fine positions x' = 2i - PAD (PAD is even,
// so the kept samples are the even e / C below): it filters all of them as vectors and keeps
// the even positions' floats.
__kernel void down_h(__global const float *t, int nh, int w, __global float *next, int nw,
                     __constant float *h1)
{
    int e0 = VW * get_global_id(0), j = get_global_id(1), n = w * C, span = 2 * nw * C;
    if (e0 >= span || j >= nh) return;
    int f0 = e0 - (PAD + R1) * C;          // float of the first tap of lane 0 in t's row
    float r[VW];
    if (f0 >= 0 && f0 + VW + 2 * R1 * C <= n) {
        floatv acc = (floatv)(0.0f);
        for (int k = 0; k <= 2 * R1; ++k)
            acc += h1[k] * loadv(t, j * n + f0 + k * C);
        to_array(acc, r);
    } else {
        for (int q = 0; q < VW; ++q) {
            float s = 0.0f;
            int fq = f0 + q, xq = (fq >= 0 ? fq / C : -((-fq + C - 1) / C)), c = fq - xq * C;
            for (int k = 0; k <= 2 * R1; ++k) {
                int x = xq + k;
                if (x >= 0 && x < w)
                    s += h1[k] * t[(j * w + x) * C + c];
            }
            r[q] = s;
        }
    }
    for (int q = 0; q < VW && e0 + q < span; ++q) {
        int xe = (e0 + q) / C;
        if ((xe & 1) == 0)
            next[(j * nw + (xe >> 1)) * C + (e0 + q - xe * C)] = r[q];
    }
}

// synthesis, across the rows: u[j][x] = (h2 * up(s))[.][x + PAD] along x, u is ch x w (one work
// item per pixel, all channels). Every tap lands inside s (its level has PAD >= R2 samples more
// on each side), so nothing is checked.
__kernel void up_h(__global const float *s, int ch, int cw, __global float *u, int w, __constant float *h2p)
{
    int x = get_global_id(0), j = get_global_id(1);
    if (x >= w || j >= ch) return;
    int ux = x + PAD - R2, p = ux & 1, base = (ux + p) >> 1;
    for (int c = 0; c < C; ++c) {
        float acc = 0.0f;
        for (int k = 0; k <= R2; ++k)
            acc += h2p[2 * k + p] * s[(j * cw + base + k) * C + c];
        u[(j * w + x) * C + c] = acc;
    }
}

// (h2 * up(s))[y + PAD][x + PAD] for channel c from the row-upsampled u (ch x w): the taps down
// the column; all inside u
inline float down_up(__global const float *u, int w, __constant float *h2p, int y, int x, int c)
{
    int uy = y + PAD - R2, p = uy & 1, base = (uy + p) >> 1;
    float s = 0.0f;
    for (int k = 0; k <= R2; ++k)
        s += h2p[2 * k + p] * u[((base + k) * w + x) * C + c];
    return s;
}

// one output sample of a level: (g * (a - m))[y][x] + the coarse term (if has_coarse), checked
inline float synth_px(__global const float *a, int h, int w, float m, __global const float *u,
                      int has_coarse, __constant float *h2p, __constant float *g, int y, int x, int c)
{
    float s = 0.0f;
    for (int dy = -RG; dy <= RG; ++dy) {
        if (y + dy < 0 || y + dy >= h) continue;
        for (int dx = -RG; dx <= RG; ++dx)
            if (x + dx >= 0 && x + dx < w)
                s += g[(dy + RG) * (2 * RG + 1) + dx + RG] * (a[((y + dy) * w + x + dx) * C + c] - m);
    }
    return has_coarse ? s + down_up(u, w, h2p, y, x, c) : s;
}

// one level of the synthesis minus the offset (level 0: its border ring's mean; else zeros):
// out = g * (a - mean) + h2 * up(coarse), the latter from u = up_h(coarse). One work item per
// VW floats of RB (1 or 2) rows, which share their input rows' loads; those whose g taps all
// fall inside the level take the unchecked path.
__kernel void synth(__global const float *a, int h, int w, __global const float *mean_tab,
                    __global const float *u, int has_coarse, __constant float *h2p,
                    __constant float *g, float g_sum, __global const float *offset_tab, __global float *out)
{
    int f = VW * get_global_id(0), y = RB * get_global_id(1), n = w * C;
    if (f >= n || y >= h) return;
    float r[VW];
    if (y >= RG && y + RB - 1 + RG < h && f >= C * RG && f + VW + C * RG <= n) {
        floatv base = -g_sum * lanes(mean_tab, f) - lanes(offset_tab, f);
        floatv acc[RB];
        for (int b = 0; b < RB; ++b) acc[b] = base;
        for (int dy = -RG; dy <= RG + RB - 1; ++dy)      // input rows y + dy
            for (int dx = -RG; dx <= RG; ++dx) {
                floatv v = loadv(a, (y + dy) * n + f + C * dx);
                for (int b = 0; b < RB; ++b)           // output row y + b: its tap dy - b
                    if (dy - b >= -RG && dy - b <= RG)
                        acc[b] += g[(dy - b + RG) * (2 * RG + 1) + dx + RG] * v;
            }
        for (int b = 0; b < RB; ++b) {
            if (has_coarse) {   // the coarse term's taps down the column: the same along the row
                int uy = y + b + PAD - R2, p = uy & 1, base_row = (uy + p) >> 1;
                for (int k = 0; k <= R2; ++k)
                    acc[b] += h2p[2 * k + p] * loadv(u, (base_row + k) * n + f);
            }
            to_array(acc[b], r);
            storev(out, (y + b) * n, f, n, r);
        }
    } else {
        for (int b = 0; b < RB && y + b < h; ++b) {
            for (int k = 0; k < VW && f + k < n; ++k) {
                int x = (f + k) / C, c = f + k - x * C;
                r[k] = synth_px(a, h, w, mean_tab[c * VW], u, has_coarse, h2p, g, y + b, x, c)
                       - offset_tab[c * VW];
            }
            storev(out, (y + b) * n, f, n, r);
        }
    }
}

// the lane table of level 0's synthesis's mean over the canvas's border ring; one work item
__kernel void ring_mean(__global const float *a, int h, int w, __global const float *mean_tab,
                        __global const float *u, __constant float *h2p, __constant float *g,
                        __global float *offset_tab)
{
    float o[C];
    for (int c = 0; c < C; ++c) {
        float m = mean_tab[c * VW], s = 0.0f;
        for (int x = 0; x < w; ++x)
            s += synth_px(a, h, w, m, u, 1, h2p, g, 0, x, c) + synth_px(a, h, w, m, u, 1, h2p, g, h - 1, x, c);
        for (int y = 1; y < h - 1; ++y)
            s += synth_px(a, h, w, m, u, 1, h2p, g, y, 0, c) + synth_px(a, h, w, m, u, 1, h2p, g, y, w - 1, c);
        o[c] = s / (float)(2 * w + 2 * (h - 2));
    }
    for (int c0 = 0; c0 < C; ++c0)
        for (int k = 0; k < VW; ++k) offset_tab[c0 * VW + k] = o[(c0 + k) % C];
}
