// Uniform-radius polygonal blur in one launch (runtime_cl/polygon_uniform.py).
//
// Every pixel shares one kernel, so MHU21's directional differences (eq. 9) are a few fixed taps
// on the fixed-point image q: G_d(p) = sum_t v_t q(p - o_t), no splatting. A worker sweeps a
// region of rows top down and keeps, per edge direction d = (a, b), the directional
// prefix sums (eq. 10) of the last |b| rows in a ring, and the vertical sum (eq. 11) per column:
//   b > 0: P(x, y) = P(x - a, y - b) + G(x, y)                 (the row b above)
//   b < 0: U(x, y) = U(x + a, y + b) + G(x, y),  P = G - U      (the suffix along +d, from the
//          row |b| above: every line's terms sum to zero, so the prefix is minus the rest)
//   b = 0: P(x, y) = P(x - 1, y) + G(x, y)                     (along the row, serially)
// Out(x, y) = Out(x, y - 1) + sum_d P_d(x, y). A region starts from the exact state of the row
// above it: P (or U) from the taps of the directional prefix of d's terms (`itaps`), and the
// vertical sum from the kernel's column runs on column sums of q (`events`).
//
// Lanes: region lane L is column X0 + L / NC, channel L % NC (the image's interleaving), so all
// channels go through one pass; 16 lanes per vector. Region columns [X0, X1) cover every column
// where some G_d is non-zero; q holds zeros outside the image and covers every tap.
// Exactness: G in int32 (the host bounds sum |v_t| |q| < 2^31), everything else in wrapping
// 64-bit integers, so sums are exact and independent of order. With `stream` (large outputs,
// the host aligns them to a cache line) colour vectors are stored non-temporally: whole lines
// the cache neither reads first nor keeps.
//
// -D constants: NC (channels), NDIR (directions), RB (ring rows = max |b| + 1), PAD (zero lanes
// either side of a ring row, a multiple of 16 >= max a * NC), CH (vectors per step of the image's
// columns: the taps' offsets are read once per CH vectors).
#pragma OPENCL EXTENSION cl_khr_fp64 : enable

// Vectors at any element-aligned address with plain loads and stores (PoCL calls, rather than
// inlines, vloadn/vstoren).
typedef int int16u __attribute__((ext_vector_type(16), aligned(4)));
typedef long long16u __attribute__((ext_vector_type(16), aligned(8)));
typedef float float16u __attribute__((ext_vector_type(16), aligned(4)));
typedef uint uint16u __attribute__((ext_vector_type(16), aligned(4)));
#define LOADI(p) (*(__global const int16u *)(p))
#define LOADL(p) (*(__global const long16u *)(p))
#define STOREL(p, v) (*(__global long16u *)(p) = (v))

// Largest |colour| of the n floats of a row as float bits: compared as integers, NaN and inf
// rank above every finite value, so one maximum also tells whether the image is finite.
inline uint row_peak(__global const float *image, const int n) {
    __global const uint *row = (__global const uint *)image;
    uint16 m = 0;
    int l = 0;
    for (; l + 16 <= n; l += 16) m = max(m, *(__global const uint16u *)(row + l) & 0x7fffffffu);
    uint s = max(max(max(m.s0, m.s1), max(m.s2, m.s3)), max(max(m.s4, m.s5), max(m.s6, m.s7)));
    s = max(s, max(max(max(m.s8, m.s9), max(m.sa, m.sb)), max(max(m.sc, m.sd), max(m.se, m.sf))));
    for (; l < n; ++l) s = max(s, row[l] & 0x7fffffffu);
    return s;
}

// rint of 16 floats, as integers: x +- 2^23 - (+-2^23) rounds to the nearest, ties to even,
// below 2^23, where floats are integers already (a few vector ops; PoCL expands
// convert_int16_rte to some twenty).
inline int16 rint16(const float16 x) {
    const uint16 bits = as_uint16(x);
    const float16 m = as_float16((bits & 0x80000000u) | 0x4b000000u);   // copysign(2^23, x)
    const int16 small = as_int16(bits & 0x7fffffffu) < 0x4b000000;    // |x| < 2^23
    return convert_int16(as_float16((as_int16((x + m) - m) & small) | (as_int16(x) & ~small)));
}

// q row of image row y: rint(colour * scale) (an exact float scaling), zeros outside the image;
// lane l of the row is image lane l - LO of that row (LO zero lanes left of the image).
inline void quantise_row(__global const float *image, const int W, const int H, const float scale,
                         const int y, __global int *row, const int QL, const int LO) {
    const int inside = y >= 0 && y < H, hi = inside ? LO + W * NC : 0;
    __global const float *src = image + (size_t)(inside ? y : 0) * W * NC - LO;
    int l = 0;
    for (; l < (inside ? LO : QL); ++l) row[l] = 0;
    for (; l + 16 <= hi; l += 16)
        *(__global int16u *)(row + l) =
            rint16(*(__global const float16u *)(src + l) * scale);
    for (; l < hi; ++l) row[l] = convert_int_rte(src[l] * scale);
    for (; l < QL; ++l) row[l] = 0;
}

#define NONFINITE 0x7fffffff

// Fixed-point exponent e from the image's peak m (float bits; runtime_cl.polygon_uniform
// .exponent_bits): the largest with 2^e peak < 2^(30 - sbits), capped at 126, 0 for a black
// image; NONFINITE if a colour is NaN or inf.
inline int fixed_point_exponent(const uint m, const int sbits) {
    if (m >= 0x7f800000u) return NONFINITE;
    if (m == 0) return 0;
    const int eb = m >> 23;   // peak < 2^E (frexp's exponent), also for subnormal peaks
    const int E = eb ? eb - 126 : 32 - (int)clz(m) - 149;
    return min(30 - E - sbits, 126);
}

inline int slot(int y) { return ((y % RB) + RB) % RB; }

// G_d at the 16 lanes from qv: taps (first, n with weight +1, then -1, then others in tval).
inline int16 gather(__global const int *qv, __global const int *toff, __global const int *tval,
                    const int4 ti) {
    int16 g = 0;
    int t = ti.x;
    for (const int e = t + ti.y; t < e; ++t) g += LOADI(qv + toff[t]);
    for (const int e = t + ti.z; t < e; ++t) g -= LOADI(qv + toff[t]);
    for (const int e = t + ti.w; t < e; ++t) g += LOADI(qv + toff[t]) * tval[t];
    return g;
}

// The same for CH consecutive vectors: each tap's offset is read once for all of them.
inline void gather_chunk(__global const int *qv, __global const int *toff,
                         __global const int *tval, const int4 ti, int16 *g) {
    for (int c = 0; c < CH; ++c) g[c] = 0;
    int t = ti.x;
    for (const int e = t + ti.y; t < e; ++t) {
        __global const int *p = qv + toff[t];
        for (int c = 0; c < CH; ++c) g[c] += LOADI(p + 16 * c);
    }
    for (const int e = t + ti.z; t < e; ++t) {
        __global const int *p = qv + toff[t];
        for (int c = 0; c < CH; ++c) g[c] -= LOADI(p + 16 * c);
    }
    for (const int e = t + ti.w; t < e; ++t) {
        __global const int *p = qv + toff[t];
        for (int c = 0; c < CH; ++c) g[c] += LOADI(p + 16 * c) * tval[t];
    }
}

// Advances direction d at vector v of the row (ring rows cur, prv already offset by -a NC for
// b > 0 and +a NC for b < 0) and returns its P; b = 0 runs along the row, lane by lane, with
// the running sums per channel `run` and the channel `ch` of the next lane.
inline long16 advance(const int2 d, const int16 g, const int v, __global long *cur,
                      __global const long *prv, long *run, int *ch) {
    const long16 gl = convert_long16(g);
    if (d.y > 0) {
        const long16 p = LOADL(prv + 16 * v) + gl;
        STOREL(cur + 16 * v, p);
        return p;
    }
    if (d.y < 0) {
        const long16 u = LOADL(prv + 16 * v) + gl;
        STOREL(cur + 16 * v, u);
        return gl - u;
    }
    int gs[16];
    long ps[16];
    *(int16 *)gs = g;
    int c = *ch;
    for (int j = 0; j < 16; ++j) {
        run[c] += gs[j];
        ps[j] = run[c];
        c = c + 1 == NC ? 0 : c + 1;
    }
    *ch = c;
    return *(long16 *)ps;
}

// Work sharing. The rows are cut into sub-bands of SUB rows, held in regions [next, end) of
// sub-bands, one 32-bit word each in `slots` (next | end << 16): worker i (a work item) owns slot
// i and claims its next sub-band from it. A worker with nothing left (on arrival too) takes a
// region no worker owns whole, or else the bottom half of the region with the most sub-bands
// unclaimed, if that half has at least `min_take` of them, into its own slot; the owner keeps
// the top half. So a worker that starts late (a busy machine; or a PoCL thread the OS queued
// behind another one) still takes half of what is left, and a worker sweeps each of its
// regions top down with one start-up: consecutive sub-bands carry the state over.
inline int claim(volatile __global uint *slot) {
    uint w = atomic_or(slot, 0u);
    for (;;) {
        const uint n = w & 0xffffu, e = w >> 16;
        if (n >= e) return -1;
        const uint old = atomic_cmpxchg(slot, w, (n + 1) | (e << 16));
        if (old == w) return (int)n;
        w = old;
    }
}

inline int take(volatile __global uint *slots, const int nslots, const int me,
                const int min_take) {
    const int owners = get_global_size(0);   // slots from here on belong to no worker
    for (;;) {
        int best = -1, most = 0;   // most: sub-bands the taker would get (+ 2^16: a whole one)
        uint bw = 0;
        for (int r = 0; r < nslots; ++r) {
            const uint w = atomic_or(slots + r, 0u);
            const int left = (int)(w >> 16) - (int)(w & 0xffffu);
            const int gain = r >= owners ? (left ? 0x10000 + left : 0) : left / 2;
            if (gain > most) { best = r; bw = w; most = gain; }
        }
        if (best < 0 || (best < owners && most < max(min_take, 1))) return -1;
        const uint n = bw & 0xffffu, e = bw >> 16, mid = best >= owners ? n : e - (uint)most;
        if (atomic_cmpxchg(slots + best, bw, n | (mid << 16)) == bw) {   // the owner: [n, mid)
            atomic_xchg(slots + me, (mid + 1) | (e << 16));
            return (int)mid;
        }
    }
}

#define QROW(y) (qr + (size_t)((((y) % QR) + QR) % QR) * QL)

// A worker's state at row y0 - 1, exact: q rows y0 - QROW0 .. y0 + QLAST, the ring rows
// y0 - |b| .. y0 - 1 and the column sums of row y0 - 1.
inline void start_region(const int y0, __global const float *image, const int W, const int H,
                         const float scale, const int LO, __global int *qr, const int QR,
                         const int QL, const int QROW0, const int QLAST, const int QLANE0,
                         const int nvec, const int vc0, const int vc1, __global const int2 *dirs,
                         __global const int *istart, __global const int4 *itaps,
                         __global const int4 *events, const int n_events, __global long *ring,
                         const int RLP, __global long *acc, __global long *csum) {
    for (size_t i = 0; i < (size_t)NDIR * RB * RLP; ++i) ring[i] = 0;
    for (int y = y0 - QROW0; y <= y0 + QLAST; ++y)   // every row the start and row y0 read
        quantise_row(image, W, H, scale, y, QROW(y), QL, LO);
    // Ring state: the directional prefix of d's terms as taps (dy, lane offset, weight).
    for (int k = 0; k < NDIR; ++k) {
        const int b = dirs[k].y, nb = b < 0 ? -b : b;
        const int va = b < 0 ? vc0 : 0, vb = b < 0 ? nvec : vc1;
        for (int y = y0 - nb; y < y0; ++y) {
            __global long *row = ring + (size_t)(k * RB + slot(y)) * RLP + PAD;
            for (int t = istart[k]; t < istart[k + 1]; ++t) {
                const int4 tp = itaps[t];
                __global const int *src = QROW(y - tp.x) + QLANE0 + tp.y;
                for (int v = va; v < vb; ++v)
                    STOREL(row + 16 * v,
                           LOADL(row + 16 * v) + convert_long16(LOADI(src + 16 * v)) * (long)tp.z);
            }
        }
    }
    // Column sums of row y0 - 1: the kernel's column runs as events (dy, dx, s) on C, the sums
    // of q rows y0 - 1 - k over the kernel's rows k so far (kept in csum): each run [dy0, dy1] of
    // column dx adds C(dy1) - C(dy0 - 1) at dx. Every vector op, no carry along the rows.
    for (int v = vc0; v < vc1; ++v) STOREL(acc + 16 * (v - vc0), (long16)0);
    for (int l = 0; l < QL; l += 16) STOREL(csum + l, (long16)0);
    for (int k = events[0].x, i = 0; i < n_events; ++k) {
        __global const int *qrow = QROW(y0 - 1 - k);
        for (int l = 0; l < QL; l += 16)
            STOREL(csum + l, LOADL(csum + l) + convert_long16(LOADI(qrow + l)));
        for (; i < n_events && events[i].x == k; ++i) {
            __global const long *cs = csum + QLANE0 - events[i].y * NC;
            if (events[i].z > 0)
                for (int v = vc0; v < vc1; ++v)
                    STOREL(acc + 16 * (v - vc0), LOADL(acc + 16 * (v - vc0)) + LOADL(cs + 16 * v));
            else
                for (int v = vc0; v < vc1; ++v)
                    STOREL(acc + 16 * (v - vc0), LOADL(acc + 16 * (v - vc0)) - LOADL(cs + 16 * v));
        }
    }
}

// Row y of the sweep: G_d from the taps, each direction's ring row, the column sums, the output;
// the image row `next` (or none) is prefetched.
inline void sweep_row(const int y, __global const int *qy, __global int *toff,
                      const int nvec, const int vc0, const int vc1, const int out_lanes,
                      __global const int2 *dirs, __global const int4 *tinfo,
                      __global const int *tval, __global long *ring, const int RLP,
                      __global long *acc, const double factor, __global float *out,
                      __global long *fixed_out, const int fixed, const int stream,
                      __global const float *next) {
    int2 d[NDIR];
    int4 ti[NDIR];
    __global long *cur[NDIR];
    __global const long *prv[NDIR];
    for (int k = 0; k < NDIR; ++k) {
        d[k] = dirs[k];
        ti[k] = tinfo[k];
        cur[k] = ring + (size_t)(k * RB + slot(y)) * RLP + PAD;
        prv[k] = ring + (size_t)(k * RB + slot(y - abs(d[k].y))) * RLP + PAD
               + (d[k].y > 0 ? -d[k].x * NC : d[k].x * NC);
    }
    long run[NC];
    for (int c = 0; c < NC; ++c) run[c] = 0;
    int ch = 0;
    // left of the image only lines with b >= 0 carry on into it; right of it, b < 0
    for (int v = 0; v < vc0; ++v)
        for (int k = 0; k < NDIR; ++k)
            if (d[k].y >= 0)
                advance(d[k], gather(qy + 16 * v, toff, tval, ti[k]), v, cur[k], prv[k],
                        run, &ch);
    for (int v = vc1; v < nvec; ++v)
        for (int k = 0; k < NDIR; ++k)
            if (d[k].y < 0)
                advance(d[k], gather(qy + 16 * v, toff, tval, ti[k]), v, cur[k], prv[k],
                        run, &ch);
    for (int v0 = vc0; v0 < vc1; v0 += CH) {   // the host makes vc1 - vc0 a multiple of CH
        if (next)   // the image row the next row quantises, as far along as this one: its
                    // loads stalled the quantising (7-12 % off at 1024^2-2048^2 after an FFT)
            for (int c = 0; c < CH; ++c) __builtin_prefetch(next + 16 * (v0 - vc0 + c));
        long16 s[CH];
        for (int c = 0; c < CH; ++c) s[c] = 0;
        for (int k = 0; k < NDIR; ++k) {
            int16 g[CH];
            gather_chunk(qy + 16 * v0, toff, tval, ti[k], g);
            for (int c = 0; c < CH; ++c)
                s[c] += advance(d[k], g[c], v0 + c, cur[k], prv[k], run, &ch);
        }
        for (int c = 0; c < CH; ++c) {
            const int v = v0 + c;
            const long16 a = LOADL(acc + 16 * (v - vc0)) + s[c];
            STOREL(acc + 16 * (v - vc0), a);
            const int l0 = 16 * (v - vc0);
            const size_t o = (size_t)y * out_lanes + l0;
            if (fixed) {
                long av[16];
                *(long16 *)av = a;
                for (int j = 0; j < 16 && l0 + j < out_lanes; ++j) fixed_out[o + j] = av[j];
            } else {
                const float16 f = convert_float16(convert_double16(a) * factor);
                if (l0 + 16 <= out_lanes) {
                    __global float *dst = out + o;
                    if (stream && ((size_t)dst & 63) == 0)   // a whole line, not read first
                        __builtin_nontemporal_store(f, (__global float16 *)dst);
                    else
                        *(__global float16u *)dst = f;
                } else {
                    float fv[16];
                    *(float16 *)fv = f;
                    for (int j = 0; l0 + j < out_lanes; ++j) out[o + j] = fv[j];
                }
            }
        }
    }
}

// One work item per worker; see the file comment and the work sharing above. ctl: [0] the
// exponent (worker 0 writes it), [1] the count of start-ups, [2, 3] peak sub-bands claimed and
// done, [4] the peak, [5...] the nslots region slots.
// A start-up quantises the image rows its taps read into the worker's ring of QR rows of q
// (rows y - QROW0 .. y + QLAST while it sweeps row y), each just before its first use: the ring
// stays in the caches. Row y is ring row y mod QR.
// scratch per worker: ring NDIR x RB x (PAD + RL + PAD), column sums (vectors [vc0, vc1)), one
// row of column sums of q (QL), the taps' q offsets from the current row (n_taps).
__kernel void uniform_sweep(__global const float *image, const int W, const int H, const int LO,
                            __global int *qall, const int QR, const int QL,
                            const int QROW0, const int QLAST, const int QLANE0,
                            const int nvec, const int vc0, const int vc1, const int out_lanes,
                            __global int *ctl, const int nslots, const int SUB,
                            const int min_take, __global const int2 *dirs,
                            __global const int4 *tinfo, __global const int *tdx,
                            __global const int *tdy, __global const int *tval, const int n_taps,
                            __global const int *istart, __global const int4 *itaps,
                            __global const int4 *events, const int n_events,
                            __global long *scratch, const long scratch_stride,
                            const int sbits, const double area,
                            __global float *out, __global long *fixed_out, const int fixed,
                            const int stream)
{
    const int me = get_global_id(0), n_sub = (H + SUB - 1) / SUB;
    // The exponent needs the image's largest |colour|: the workers share that scan by sub-bands
    // too, then wait for the ones others have claimed (running workers: no deadlock).
    for (int c; (c = atomic_inc(ctl + 2)) < n_sub;) {
        uint m = 0;
        for (int y = c * SUB; y < min(H, c * SUB + SUB); ++y)
            m = max(m, row_peak(image + (size_t)y * W * NC, W * NC));
        atomic_max((volatile __global uint *)(ctl + 4), m);
        atomic_inc(ctl + 3);
    }
    while (atomic_or(ctl + 3, 0) < n_sub) {}
    const int e = fixed_point_exponent(atomic_or((volatile __global uint *)(ctl + 4), 0u), sbits);
    if (me == 0) ctl[0] = e;
    if (e == NONFINITE) return;
    const float scale = as_float((uint)(e + 127) << 23);            // 2^e
    const double factor = as_double((ulong)(1023 - e) << 52) / area;  // 2^-e / area, one rounding
    __global int *qr = qall + (size_t)me * QR * QL;
    const int RLP = nvec * 16 + 2 * PAD;
    __global long *ring = scratch + me * scratch_stride;
    __global long *acc = ring + (size_t)NDIR * RB * RLP;   // vector v at acc + 16 (v - vc0)
    __global long *csum = acc + (vc1 - vc0) * 16;
    __global int *toff = (__global int *)(csum + QL);
    volatile __global uint *slots = (volatile __global uint *)(ctl + 5);

    int sb = claim(slots + me), ys = 0;   // ys: the row of the region's start-up
    bool fresh = true;                    // sb starts a region (own sub-bands follow on)
    for (;;) {
        if (sb < 0) {
            if ((sb = take(slots, nslots, me, min_take)) < 0) break;
            fresh = true;
        }
        const int y0 = sb * SUB, y1 = min(H, y0 + SUB);
        if (fresh) {
            atomic_inc(ctl + 1);
            start_region(y0, image, W, H, scale, LO, qr, QR, QL, QROW0, QLAST, QLANE0, nvec, vc0,
                         vc1, dirs, istart, itaps, events, n_events, ring, RLP, acc, csum);
            ys = y0;
            fresh = false;
        }
        for (int y = y0; y < y1; ++y) {
            if (y > ys) quantise_row(image, W, H, scale, y + QLAST, QROW(y + QLAST), QL, LO);
            for (int t = 0; t < n_taps; ++t)   // the taps' ring rows, relative to row y's
                toff[t] = (int)(QROW(y - tdy[t]) - QROW(y)) + tdx[t];
            const int yn = y + QLAST + 1;
            sweep_row(y, QROW(y) + QLANE0, toff, nvec, vc0, vc1, out_lanes, dirs, tinfo, tval,
                      ring, RLP, acc, factor, out, fixed_out, fixed, stream,
                      yn < H ? image + (size_t)yn * W * NC : 0);
        }
        sb = claim(slots + me);   // the next sub-band of this region, or none
    }
}
