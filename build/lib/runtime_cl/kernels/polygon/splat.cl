// MHU21 polygonal splatting in exact fixed point (runtime_cl/polygon_splat.py).
//
// Every value is an integer count of 2^-e colour units, held in ulong: additions wrap modulo
// 2^64, so sums are exact and independent of order whatever the intermediate values, and the
// final pixel is right because its true value is known to fit in a long (the host picks e).
//
// Canvas: buffer k (direction d_k = (a, b), a >= 1) covers exactly the image, H x W x NC.
// Terms landing outside are folded on (`emit`) so nothing the image needs is lost:
//   * x < 0: slide along +d to the first column >= 0 (the skipped points are left of the image);
//   * y >= H (only b < 0 lines climb back): slide along +d to the first row < H;
//   * y < 0: the line's points above the image feed the vertical sum of every column they pass
//     through, i.e. a comb of stride a on row 0 (`comb` buffer a-1), +v from x until the line
//     enters row 0 (where it continues in buffer k) and -v from there;
//   * x >= W, or y >= H with b >= 0: never reach the image, dropped.
// Likewise a line with b < 0 that leaves the image upwards carries its running sum on as a comb
// (`comb_exit`); terms further along it, above the image, were folded into combs already.
// (A uniform radius has its own one-pass kernel, polygon/uniform.cl.)
//
// -D constants: NC (channels), NDIR (directions), AMAX (largest a), BMAX (largest |b|), CB
// (columns per summing work item), CHUNK (prefix-sum chunk width), BUCKETS (radius lookup
// buckets per pixel).
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
#pragma OPENCL EXTENSION cl_khr_int64_base_atomics : enable

inline int floor_div(int a, int b) { int q = a / b; return (q * b != a && ((a < 0) != (b < 0))) ? q - 1 : q; }
inline int ceil_div(int a, int b) { return -floor_div(-a, b); }

inline void add_comb(__global ulong *comb, int a, int x, int W, const ulong *v, int sign) {
    volatile __global ulong *p = (volatile __global ulong *)(comb + ((size_t)(a - 1) * W + x) * NC);
    for (int c = 0; c < NC; ++c) atom_add(p + c, sign > 0 ? v[c] : (ulong)0 - v[c]);
}

// Adds the term v at (x, y) of direction (a, b) to buffer `buf` (H x W x NC), folded. Plain
// (non-atomic) adds are safe for unfolded targets off the border zone (the host runs tiles that
// could touch the same pixel in different launches); folded terms and the border zone
// (x < AMAX, y < BMAX, y >= H - BMAX), where folded terms land, use atomics.
inline void emit(__global ulong *buf, __global ulong *comb, int a, int b, int x, int y,
                 int W, int H, const ulong *v) {
    if (x >= W) return;
    int folded = 0;
    if (x < 0) { const int k = ceil_div(-x, a); x += k * a; y += k * b; folded = 1; if (x >= W) return; }
    if (y >= H) {
        if (b >= 0) return;
        const int k = ceil_div(y - (H - 1), -b);
        x += k * a; y += k * b;
        folded = 1;
        if (x >= W) return;
    }
    if (y < 0) {
        add_comb(comb, a, x, W, v, 1);
        if (b <= 0) return;
        const int k = ceil_div(-y, b);
        x += k * a; y += k * b;
        if (x >= W) return;
        add_comb(comb, a, x, W, v, -1);
        if (y >= H) return;
        folded = 1;
    }
    __global ulong *p = buf + ((size_t)y * W + x) * NC;
    if (folded || x < AMAX || y < BMAX || y >= H - BMAX) {
        for (int c = 0; c < NC; ++c) atom_add((volatile __global ulong *)(p + c), v[c]);
    } else {
        for (int c = 0; c < NC; ++c) p[c] += v[c];
    }
}

// Spatially varying radius: each work item splats one TW x TH tile of pixels. One launch runs
// the tiles (cx + i PX, cy + j PY): their kernels (at most the host's span wide or high) cannot
// overlap, so plain adds do not race.
// q = rint(colour * unit[entry, c]) with unit = 2^e / area (one double product per channel).
__kernel void splat(__global const float *image,          // H x W x NC
                    __global const float *radius,         // H x W
                    const int W, const int H,
                    __global const float *breaks, const int n_entries, __global const int *bucket,
                    __global const int *term_start,       // n_entries + 1
                    __global const int4 *terms,           // (direction, dx, dy, value)
                    __global const double *unit,          // n_entries x NC
                    __global const int2 *dirs,            // NDIR
                    __global ulong *bufs,                 // NDIR x H x W x NC
                    __global ulong *comb,                 // AMAX x W x NC
                    const int TW, const int TH, const int PX, const int PY, const int cx,
                    const int cy, const int n_tx)
{
    const int i = get_global_id(0);
    const int x0 = (cx + (i % n_tx) * PX) * TW, y0 = (cy + (i / n_tx) * PY) * TH;
    if (x0 >= W || y0 >= H) return;
    float last_r = -1.0f;
    int e = 0;
    for (int y = y0; y < min(y0 + TH, H); ++y)
    for (int x = x0; x < min(x0 + TW, W); ++x) {
        const size_t p = (size_t)y * W + x;
        const float r = radius[p];
        if (r != last_r) { e = find_entry(breaks, n_entries, bucket, r); last_r = r; }
        ulong q[NC];
        if (!quantise(image, unit, p, e, q)) continue;
        for (int t = term_start[e]; t < term_start[e + 1]; ++t) {
            const int4 tm = terms[t];
            const int2 d = dirs[tm.x];
            ulong v[NC];
            for (int c = 0; c < NC; ++c) v[c] = q[c] * (ulong)(long)tm.w;
            emit(bufs + (size_t)tm.x * H * W * NC, comb, d.x, d.y, x + tm.y, y + tm.z, W, H, v);
        }
    }
}

// Directional prefix sum (MHU21 eq. 10) along d = (a, b) in column chunks, so every pass
// streams whole row segments. An image of W x H pixels (buffer `buf`, row-major, NC per
// pixel) is cut into chunks of CHUNK columns (a multiple of every a and of CB).
// prefix_local: within its chunk each work item computes S1(x, y) = S1(x - a, y - b) + G(x, y),
// starting from 0 where the line enters the chunk (rows in the order b asks for); G is the
// buffer itself (the splatted terms).
// prefix_carry: carry[c][u][y] = the full prefix just before the line through (x0_c + u, y)
// enters chunk c, i.e. S(x0_c + u - a, y - b), = S1 there + carry[c-1][u][y - b CHUNK / a].
// Carry rows run from -CPAD to H + CPAD (zeros outside the image) so readers need no checks.
// The full prefix is S(x, y) = S1(x, y) + carry[c][(x - x0) % a][y - b ((x - x0) / a)];
// `vsum` adds it on the fly.
#define CPAD (BMAX * (CHUNK / 1))
#define CROWS(BH) ((BH) + 2 * CPAD)

__kernel void prefix_local(__global ulong *buf, const long base, const int BW, const int BH,
                           const int a, const int b)
{
    const int x0 = get_global_id(0) * CHUNK;
    if (x0 >= BW) return;
    const int n = (min(x0 + CHUNK, BW) - x0) * NC, an = a * NC;
    ulong acc[CHUNK * NC];
    buf += base;
    for (int i = 0; i < BH; ++i) {
        const int y = b >= 0 ? i : BH - 1 - i;
        __global ulong *row = buf + ((size_t)y * BW + x0) * NC;
        for (int j = 0; j < n; ++j) acc[j] = row[j];
        const int yp = y - b;
        if (b == 0) {
            for (int j = an; j < n; ++j) acc[j] += acc[j - an];
        } else if (yp >= 0 && yp < BH) {
            __global const ulong *prev = buf + ((size_t)yp * BW + x0) * NC;
            for (int j = an; j < n; ++j) acc[j] += prev[j - an];
        }
        for (int j = 0; j < n; ++j) row[j] = acc[j];
    }
}

// One work item: the carries of every chunk (sequential over chunks; a x CROWS x NC per chunk).
__kernel void prefix_carry(__global const ulong *buf, const long base, const int BW, const int BH,
                           const int a, const int b, __global ulong *carry, const long carry_base)
{
    if (get_global_id(0) != 0) return;
    buf += base;
    carry += carry_base;
    const int n_chunks = (BW + CHUNK - 1) / CHUNK, shift = b * (CHUNK / a), rows = CROWS(BH);
    for (long i = 0; i < (long)n_chunks * a * rows * NC; ++i) carry[i] = 0;
    for (int ch = 1; ch < n_chunks; ++ch) {
        __global ulong *cur = carry + (size_t)ch * a * rows * NC;
        __global const ulong *prv = cur - (size_t)a * rows * NC;
        for (int u = 0; u < a; ++u)
            for (int y = 0; y < BH; ++y) {
                const int yp = y - b, yc = y - shift;
                if (yp < 0 || yp >= BH) continue;
                const int x = ch * CHUNK + u - a;
                for (int c = 0; c < NC; ++c) {
                    ulong v = buf[((size_t)yp * BW + x) * NC + c];
                    if (yc >= 0 && yc < BH) v += prv[((size_t)u * rows + yc + CPAD) * NC + c];
                    cur[((size_t)u * rows + y + CPAD) * NC + c] = v;
                }
            }
    }
}

inline ulong full_prefix(__global const ulong *buf, __global const ulong *carry, int BW, int BH,
                         int a, int b, int x, int y, int c) {
    const int ch = x / CHUNK, off = x - ch * CHUNK, u = off % a, yc = y - b * (off / a);
    return buf[((size_t)y * BW + x) * NC + c]
         + carry[(((size_t)ch * a + u) * CROWS(BH) + yc + CPAD) * NC + c];
}

// A line with b < 0 that leaves the region upwards carries its prefix on as a comb of stride a
// (radius-map path; see `emit`). One work item per column.
__kernel void comb_exit(__global const ulong *buf, const long base, const int W, const int H,
                        const int a, const int b, __global const ulong *carry, const long carry_base,
                        __global ulong *comb)
{
    const int x = get_global_id(0);
    if (x >= W || x + a >= W) return;
    ulong s[NC];
    for (int c = 0; c < NC; ++c) s[c] = 0;
    for (int y = 0; y < min(-b, H); ++y)
        for (int c = 0; c < NC; ++c) s[c] += full_prefix(buf + base, carry + carry_base, W, H, a, b, x, y, c);
    for (int c = 0; c < NC; ++c) comb[((size_t)(a - 1) * W + x + a) * NC + c] += s[c];
}

// In-place prefix sum of each comb with stride a (one work item per (a, u, channel)).
__kernel void comb_prefix(__global ulong *comb, const int W)
{
    int id = get_global_id(0);
    const int c = id % NC;
    id /= NC;
    int a = 1;
    while (id >= a) { id -= a; ++a; }          // id -> (a, u) with u < a
    if (a > AMAX) return;
    __global ulong *row = comb + (size_t)(a - 1) * W * NC;
    ulong s = 0;
    for (int x = id; x < W; x += a) { s += row[x * NC + c]; row[x * NC + c] = s; }
}

// Vertical prefix sum (MHU21 eq. 11) of the sum over directions (eq. 9) of the full directional
// prefixes, plus the combs on row 0, converted to colour: out = value * factor (2^-e). CB
// columns per work item; with `fixed` != 0 the int64 sums are written instead (tests compare
// them bit for bit).
__kernel void vsum(__global const ulong *bufs, __global const int2 *dirs, const int W, const int H,
                   __global const ulong *carry, __global const ulong *comb,
                   __constant double *factor, __global float *out, __global long *fixed_out,
                   const int fixed)
{
    const int x0 = get_global_id(0) * CB;
    if (x0 >= W) return;
    const int n = min(CB, W - x0);
    const size_t plane = (size_t)W * H * NC;
    const size_t cplane = (size_t)((W + CHUNK - 1) / CHUNK) * AMAX * CROWS(H) * NC;
    ulong s[CB * NC];
    long cbase[NDIR * CB];   // carry index of (column, row 0)
    for (int i = 0; i < CB; ++i) {
        const int x = min(x0 + i, W - 1), ch = x / CHUNK, off = x - ch * CHUNK;
        for (int k = 0; k < NDIR; ++k) {
            const int2 d = dirs[k];
            cbase[k * CB + i] = (long)k * cplane
                + (((long)ch * d.x + off % d.x) * CROWS(H) + CPAD - d.y * (off / d.x)) * NC;
        }
        for (int c = 0; c < NC; ++c) {
            ulong v = 0;
            if (i < n)
                for (int a = 0; a < AMAX; ++a) v += comb[((size_t)a * W + x0 + i) * NC + c];
            s[i * NC + c] = v;
        }
    }
    for (int y = 0; y < H; ++y) {
        for (int k = 0; k < NDIR; ++k) {
            __global const ulong *row = bufs + k * plane + ((size_t)y * W + x0) * NC;
            for (int i = 0; i < n * NC; ++i) s[i] += row[i];
            for (int i = 0; i < n; ++i) {
                __global const ulong *cr = carry + cbase[k * CB + i] + (long)y * NC;
                for (int c = 0; c < NC; ++c) s[i * NC + c] += cr[c];
            }
        }
        const size_t o = ((size_t)y * W + x0) * NC;
        if (fixed) {
            for (int i = 0; i < n * NC; ++i) fixed_out[o + i] = (long)s[i];
        } else {
            for (int i = 0; i < n; ++i)
                for (int c = 0; c < NC; ++c)
                    out[o + i * NC + c] = (float)((double)(long)s[i * NC + c] * factor[c]);
        }
    }
}
