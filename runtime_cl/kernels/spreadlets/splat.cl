// Exact (race-free, deterministic) splatting with private tiles. Needs psf/psf_space.cl first.
//
// Work item t owns the input tile [x0, x0 + tile_w) x [y0, y0 + tile_h) and a private buffer
// covering the canvas pixels those pixels can reach: (tile_h + 2 PAD) rows of (tile_w + 2 PAD)
// pixels, GROUPS planes (LAP_GROUP, DENSE_GROUP, ROW_GROUP below). If the tile has a lit pixel it
// zeroes its buffer and adds into it sequentially, so plain += is exact. merge_tiles then sums the
// overlapping tiles of each canvas pixel in a fixed order (bit-reproducible results) into at most
// two canvas planes: the Laplacian (to integrate) and the image (dense and row planes summed).
// Canvas coordinates: input pixel (x, y) sits at (x + PAD, y + PAD).
//
// Pixels are splat by runs: up to RUN_MAX consecutive non-empty pixels of a tile row with the
// same PSF cell (common: PSF coordinates vary smoothly over a scene). A spreadlet adds the
// run's colours times its value to one contiguous segment of a canvas row; a dense PSF row
// adds to its canvas row for each pixel of the run in turn (same order of terms per output
// pixel as pixel by pixel, so dense results do not depend on the runs). The device database
// sorts each cell's spreadlets by (dy, dx), so the segments also advance row by row.
// Measured on a 2-core PoCL CPU, 1024^2 RGB, discs up to r = 100 with a 1 px soft rim, laid
// out like a defocused photograph (runtime_cl.bench --layout defocus), vs full-width row bands
// splatting pixel by pixel: spreadlets 878 -> 2895 M per CPU-second; the demo database (sorted
// by (dx, dy) in its file) 288 -> 2834. Blocks of several rows per run were 1.8x slower.
//
// A tile pixel is one float (OC = 1) or a float4 whose 4th lane stays 0 (OC = 3): one vector
// add per spreadlet measured 419 vs 309 M spreadlets/s for three scalar adds on PoCL; dropping
// the 4th lane (3 floats per pixel) measured no faster. Runs are added 4 (spreadlets) or 2
// (dense rows) pixels per vector op.
//
// Build options (beside psf/psf_space.cl's):
//   CC, DC, OC   colour channels (1, 3 or 4), database channels (1 or 3), output channels
//                = max(CC, DC); see prelude/pixels.cl
//   PAD          canvas padding: largest spreadlet offset or dense radius + 1
//   DENSE_ALL    1: every pixel splats its dense PSF (LSR18's Splat baseline) into DENSE_GROUP;
//                0: each cell as its kind says (fast[cell], runtime_cl/psf/upload.py KIND_*):
//                0 Laplacian spreadlets into LAP_GROUP, 1 its dense PSF into DENSE_GROUP (the fast
//                track), 2 row differences into ROW_GROUP
//   LAP_GROUP, DENSE_GROUP, ROW_GROUP  the tile plane of each (-1: the frame draws none of them).
//                ROW_GROUP holds row differences (database basis "rows" or "dual"), not a
//                Laplacian: merge_tiles writes each of its canvas rows' prefix sums (in double),
//                which is the image. With ROTATE a half turn draws minus the stored difference at
//                1 - x (other turns of row differences: see DUAL).
//   DUAL, CELLS  DUAL 1: a database of basis "dual", whose CELLS cells are stored twice (C, P, V
//                and fast of length 2 CELLS, runtime_cl/psf/upload.py device_spreadlets): as
//                Laplacian spreadlets (cells 0 .. CELLS - 1), drawn at turns other than 0 and pi,
//                and as row differences (cells CELLS ..), drawn unturned and half-turned
//   GROUPS       planes per tile (those of the three that are >= 0)
//   RUN_MAX      longest run of same-cell pixels splat together (default 128)
//   ROTATE       1: every pixel's PSF is turned by its angle (spreadlets/rotate.cl, which must come before
//                this file); runs then also need the same angle. Spreadlet offsets are turned
//                (the Laplacian and its integration commute with rotation) and land on pixels
//                as SPREADLET_BILINEAR says; dense PSFs are turned as spreadlets/rotate.cl says.
//                PAD must then hold the turned PSFs (SpreadletDatabase.rotated_pad). 0: the
//                angle and dense_sum buffers are not read, the code is the unrotated one.
//   SPREADLET_BILINEAR  (with ROTATE) 1: turned spreadlets are shared bilinearly among four
//                pixels, 0: moved to the nearest pixel (splat_spreadlets_rotated)
//   BANK         1 (with ROTATE 0): the database buffers hold an angle bank
//                (runtime_cl/spreadlets/angle_bank.py): cell i turned by 2 pi k / bank_k[i] is
//                entry bank_base[i] + k; a pixel takes the entry of the angle nearest its own and
//                splats it unturned (row-difference entries come half-turned already). Runs then
//                need the same cell and angle index.

#ifndef RUN_MAX
#define RUN_MAX 128
#endif
#ifndef ROTATE
#define ROTATE 0
#endif
#ifndef SPREADLET_BILINEAR
#define SPREADLET_BILINEAR 1
#endif
#ifndef BANK
#define BANK 0
#endif
#if ROW_GROUP >= 0
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
#endif

#if BANK
// The bank entry of cell for angle a (radians): the nearest of its K angles 2 pi k / K. The
// rounding is done by adding 1.5 * 2^23 (rint is a library call on PoCL; |t| <= K < 2^22).
inline int bank_entry(const int cell, const float angle, __global const int *bank_k,
                      __global const int *bank_base) {
    const int K = bank_k[cell];
    const float t = fmod(angle, 2.0f * M_PI_F) * ((float)K * (0.5f * M_1_PI_F));
    int k = (int)((t + 0x1.8p23f) - 0x1.8p23f) % K;
    if (k < 0) k += K;
    return bank_base[cell] + k;
}
#define CELL_AT(i) bank_entry(psf_cell(coords + (i) * PSF_NS, psf_thr, psf_bucket), angle[i], bank_k, bank_base)
#else
#define CELL_AT(i) psf_cell(coords + (i) * PSF_NS, psf_thr, psf_bucket)
#endif

// vectors of 2 and 4 float4 pixels at float4 alignment (vload8/vload16 are calls on PoCL)
typedef float8 float8_a16 __attribute__((aligned(16)));
typedef float16 float16_a16 __attribute__((aligned(16)));

// pix_t, DB_VALUE, COLOUR, IS_ZERO: prelude/pixels.cl

// One dense PSF row (side pixels of values dv) times colour col, added at row[0 .. side).
inline void dense_row(__global pix_t *row, const pix_t col, const int side, __global const float *dv) {
    int ox = 0;
#if OC != 1
    // two pixels per 8-wide vector op: 1.15x the float4 loop's throughput
    const float8 c2 = (float8)(col, col);
    __global float *rowf = (__global float *)row;
    for (; ox + 1 < side; ox += 2) {
        const float8 w = (float8)(DB_VALUE(dv, ox), DB_VALUE(dv, ox + 1));
        *(__global float8_a16 *)(rowf + 4 * ox) += w * c2;
    }
#endif
    for (; ox < side; ++ox) row[ox] += DB_VALUE(dv, ox) * col;
}

// One spreadlet of value v times the colours of a run of n pixels, added at dst[0 .. n).
inline void splat_run(__global pix_t *dst, const pix_t v, const pix_t *run_col, const int n) {
    int k = 0;
#if OC != 1
    // four pixels per 16-wide vector op (two AVX ops): 1.3-1.4x the float4 loop's throughput
    const float16 v4 = (float16)(v, v, v, v);
    __global float *d = (__global float *)dst;
    const float *c = (const float *)run_col;
    for (; k + 3 < n; k += 4) *(__global float16_a16 *)(d + 4 * k) += v4 * *(const float16_a16 *)(c + 4 * k);
#endif
    for (; k < n; ++k) dst[k] += v * run_col[k];
}

// The dense PSF of radius r times the colours of a run of n pixels; dst: the tile position of
// the first pixel's PSF corner (offset (-r, -r)). Row by row, so a PSF row of the whole run
// (side + n pixels) stays in L1 while the run's pixels add to it; each row only over its
// non-zero span [first, end) (a disc's zero corners are ~22 % of its crop).
inline void splat_dense(__global pix_t *dst, const int buf_w, const pix_t *run_col, const int n,
                        const int r, __global const float *dv, __global const int2 *span) {
    const int side = 2 * r + 1;
#if BANK
    long at = 0;   // a bank stores each row's span only, rows one after another (angle_bank.py)
#endif
    for (int oy = 0; oy < side; ++oy) {
        const int2 s = span[oy];
        __global pix_t *row = dst + (long)oy * buf_w + s.x;
#if BANK
        __global const float *dvrow = dv + at * DC;
        at += s.y - s.x;
#else
        __global const float *dvrow = dv + ((long)oy * side + s.x) * DC;
#endif
        for (int k = 0; k < n; ++k) dense_row(row + k, run_col[k], s.y - s.x, dvrow);
    }
}

#if ROTATE

// Spreadlets j0 .. j1 - 1 turned by cs times the colours of a run of n pixels; lap: the tile
// position of the run's first pixel. A quarter turn moves each to an integer offset (exact).
// Other angles: SPREADLET_BILINEAR 1 shares each spreadlet among the four pixels around its
// turned position (bilinear weights, 4 writes), 0 moves it to the nearest pixel (1 write).
// Rounding displaces each Laplacian value by up to 0.7 px independently, and the integration
// turns that into low-frequency error: for an exact-Laplacian capsule (radius 4-10 px, 10-20 px
// long) nearest rounding measured 8-56 % L1 error against the turned PSF and 83-106 % of its
// energy, bilinear sharing 0.7-2.6 % L1 and 99.9-100.2 % (it keeps the spreadlets' sum and
// first moments exactly, so the integrated PSF stays compact).
inline void splat_spreadlets_rotated(__global pix_t *lap, const int buf_w, __global const short2 *P,
                                     __global const float *V, const long j0, const long j1,
                                     const pix_t *run_col, const int n, const float2 cs) {
#if SPREADLET_BILINEAR
    if (!is_quarter_turn(cs)) {
        for (long j = j0; j < j1; ++j) {
            const short2 p = P[j];
            const float2 f = rotate_xy(cs, (float)p.x, (float)p.y);
            const int ix = floor_px(f.x), iy = floor_px(f.y);
            const float wx = f.x - (float)ix, wy = f.y - (float)iy;
            const pix_t v = DB_VALUE(V, j);
            __global pix_t *d = lap + (long)iy * buf_w + ix;
            splat_run(d, v * ((1.0f - wx) * (1.0f - wy)), run_col, n);
            splat_run(d + 1, v * (wx * (1.0f - wy)), run_col, n);
            splat_run(d + buf_w, v * ((1.0f - wx) * wy), run_col, n);
            splat_run(d + buf_w + 1, v * (wx * wy), run_col, n);
        }
        return;
    }
#endif
    for (long j = j0; j < j1; ++j) {
        const short2 p = P[j];
        const float2 f = rotate_xy(cs, (float)p.x, (float)p.y);
        splat_run(lap + (long)round_px(f.y) * buf_w + round_px(f.x), DB_VALUE(V, j), run_col, n);
    }
}

// The dense PSF of radius r turned by cs (spreadlets/rotate.cl: inverse-mapped, scaled to keep its energy)
// times the colours of a run of n pixels; dst: the tile position of the run's first pixel.
// Other than quarter turns, the first walk over the support keeps each turned value in the work
// item's scratch (in walk order; a NaN pattern where R^-1 d falls outside the crop), and the
// second reads them back instead of sampling the PSF again: the same values added in the same
// order (bitwise the same image), each PSF sampled once. Each row's columns are kept too: the
// second walk recomputes no test, which the compiler might contract differently in two places.
#define NO_TAP 0x7fc0dead  // a quiet NaN: finite PSF values never have it
inline void splat_dense_rotated(__global pix_t *dst, const int buf_w, const pix_t *run_col, const int n,
                                const int r, __global const float *dv, const float4 stored, const float4 box,
                                const float2 cs, __global float4 *scratch) {
    const int reach = turned_reach(r, cs);
    float4 v;
    int lo, hi;
    if (is_quarter_turn(cs)) {
        for (int dy = -reach; dy <= reach; ++dy) {
            __global pix_t *row = dst + (long)dy * buf_w;
            turned_cols(cs, box, reach, dy, &lo, &hi);
            for (int dx = lo; dx <= hi; ++dx) {
                if (!turned_value(dv, r, cs, dx, dy, &v)) continue;
                const pix_t w = TO_PIX(v);
                for (int k = 0; k < n; ++k) row[dx + k] += w * run_col[k];
            }
        }
        return;
    }
    float4 turned = (float4)0.0f;
    int m = 0;
    for (int dy = -reach; dy <= reach; ++dy) {
        turned_cols(cs, box, reach, dy, &lo, &hi);
        scratch[m++] = (float4)(as_float(lo), as_float(hi), 0.0f, 0.0f);   // the row's columns
        for (int dx = lo; dx <= hi; ++dx, ++m) {
            if (turned_value(dv, r, cs, dx, dy, &v)) {
                turned += v;
                scratch[m] = v;
            } else {
                scratch[m] = (float4)(as_float(NO_TAP));
            }
        }
    }
    const float4 scale = energy_scale(stored, turned);
    m = 0;
    for (int dy = -reach; dy <= reach; ++dy) {
        __global pix_t *row = dst + (long)dy * buf_w;
        const float4 cols = scratch[m++];
        hi = as_int(cols.y);
        for (int dx = as_int(cols.x); dx <= hi; ++dx) {
            const float4 t = scratch[m++];
            if (as_uint(t.x) == NO_TAP) continue;
            const pix_t w = TO_PIX(t * scale);
            for (int k = 0; k < n; ++k) row[dx + k] += w * run_col[k];
        }
    }
}
#endif

__kernel void splat_tiles(__global const float *colour,      // (H, W, CC)
                          __global const float *coords,      // (H, W, PSF_NS)
                          __global const float *angle,       // (H, W) radians (read if ROTATE or BANK)
                          __global const int *bank_k,        // (cells,) angles per cell (read if BANK)
                          __global const int *bank_base,     // (cells,) first bank entry (read if BANK)
                          __global const PSF_REAL *psf_thr,
                          __global const int *psf_bucket,
                          __global const long *C,            // (n+1,)
                          __global const short2 *P,          // (m,) (dx, dy), sorted (dy, dx) per cell
                          __global const float *V,           // (m, DC)
                          __global const uchar *fast,        // (n,)
                          __global const int *dense_r,       // (n,)
                          __global const long *dense_off,    // (n+1,)
                          __global const float *dense_v,     // (sum, DC)
                          __global const long *span_off,     // (n+1,)
                          __global const int2 *span,         // (rows,) non-zero [first, end) per row
                          __global const long *dense_n,      // (n,) pixels inside the spans
                          __global const float *dense_sum,   // (n, DC) sums (read if ROTATE)
                          __global const int4 *dense_box,    // (n,) non-zero box (read if ROTATE)
                          __global pix_t *tiles,             // (ntiles, GROUPS, buf_h, buf_w)
                          __global long *counts,             // (ntiles, 8): spreadlets, dense px, Laplacian
                                                             // spreadlets, their pixels' x0, x1, y0, y1, lit
                          __global float4 *scratch,          // (ntiles, (2 PAD + 1)(2 PAD + 2)) (if ROTATE)
                          const int H, const int W, const int tile_w, const int tile_h,
                          const int tiles_x) {
    const int t = get_global_id(0);
    const int x0 = (t % tiles_x) * tile_w, y0 = (t / tiles_x) * tile_h;
    const int x1 = min(x0 + tile_w, W), y1 = min(y0 + tile_h, H);
    const int buf_w = tile_w + 2 * PAD;
    const long group_stride = (long)(tile_h + 2 * PAD) * buf_w;
    __global pix_t *tile = tiles + (long)t * GROUPS * group_stride;
#if ROTATE
    __global float4 *turned_scratch = scratch + (long)t * (2 * PAD + 1) * (2 * PAD + 2);
#endif
    long n_spreadlets = 0, n_dense = 0, n_laplacian = 0;
    int lap_x0 = W, lap_x1 = -1, lap_y0 = H, lap_y1 = -1;   // pixels that drew Laplacian spreadlets
    __global long *out = counts + 8 * t;
    // a tile without a lit pixel neither zeroes nor fills its buffer: merge_tiles skips it (a depth
    // layer's pixels fill a band of the frame, so most of its tiles are empty)
    int lit = 0;
    for (int y = y0; y < y1 && !lit; ++y)
        for (int x = x0; x < x1 && !lit; ++x) lit = !IS_ZERO(COLOUR(colour, (long)y * W + x));
    out[7] = lit;
    if (!lit) {
        out[0] = out[1] = out[2] = 0;
        out[3] = lap_x0, out[4] = lap_x1, out[5] = lap_y0, out[6] = lap_y1;
        return;
    }
    for (long i = 0; i < GROUPS * group_stride; ++i) tile[i] = (pix_t)0.0f;

    pix_t run_col[RUN_MAX];
    for (int y = y0; y < y1; ++y) {
        int x = x0, next_cell = -1;  // next_cell: pixel x's cell when the last run looked it up
        while (x < x1) {
            const long i = (long)y * W + x;
            const pix_t col = COLOUR(colour, i);
            if (IS_ZERO(col)) {  // empty pixels splat nothing (LSR18: culled early)
                ++x;
                next_cell = -1;
                continue;
            }
            const int cell = next_cell >= 0 ? next_cell : CELL_AT(i);
            next_cell = -1;
#if ROTATE
            const float a = angle[i];
#endif
            // the run: pixels x .. x + n - 1, all non-empty with this cell (and angle)
            run_col[0] = col;
            int n = 1;
            while (n < RUN_MAX && x + n < x1) {
                const pix_t c = COLOUR(colour, i + n);
                if (IS_ZERO(c)) break;
                const int cn = CELL_AT(i + n);
#if ROTATE
                if (cn != cell || angle[i + n] != a) {
#else
                if (cn != cell) {
#endif
                    next_cell = cn;
                    break;
                }
                run_col[n++] = c;
            }
#if ROTATE
            const float2 cs = rotation_cs(a);
            const int turned = cs.x != 1.0f || cs.y != 0.0f;  // else: angle 0, the unrotated code
#endif
            const long centre = (long)(y - y0 + PAD) * buf_w + (x - x0 + PAD);
            x += n;
#if DUAL && ROTATE
            // a dual database: no turn and half turns (cs = (+-1, 0) exactly) draw the row
            // differences (cells CELLS .. 2 CELLS - 1), any other turn the Laplacian
            const int set = turned && cs.y != 0.0f ? 0 : CELLS;
#elif DUAL
            const int set = CELLS;
#else
            const int set = 0;
#endif
#if DENSE_ALL
            const int kind = 1;
#else
            const int kind = fast[set + cell];   // runtime_cl/psf/upload.py KIND_*
#endif
#if DENSE_GROUP >= 0
            if (kind == 1) {
                const int r = dense_r[cell];
#if ROTATE
                if (turned)
                    splat_dense_rotated(tile + DENSE_GROUP * group_stride + centre, buf_w, run_col, n, r,
                                        dense_v + dense_off[cell] * DC, stored_sum(dense_sum, cell),
                                        support_box(dense_box, cell), cs, turned_scratch);
                else
#endif
                splat_dense(tile + DENSE_GROUP * group_stride + centre - ((long)r * buf_w + r),
                            buf_w, run_col, n, r, dense_v + dense_off[cell] * DC, span + span_off[cell]);
                n_dense += dense_n[cell] * n;
                continue;
            }
#endif
            const long j0 = C[set + cell], j1 = C[set + cell + 1];
            n_spreadlets += (j1 - j0) * n;
#if ROW_GROUP >= 0
            if (kind == 2) {
                __global pix_t *row = tile + ROW_GROUP * group_stride + centre;
#if ROTATE
                // a half turn: minus each stored difference, one pixel to the right of its turned place
                const int flip = turned;
                const pix_t sign = flip ? (pix_t)(-1.0f) : (pix_t)1.0f;
                for (long j = j0; j < j1; ++j) {
                    const short2 p = P[j];
                    splat_run(row + (long)(flip ? -p.y : p.y) * buf_w + (flip ? 1 - p.x : p.x),
                              sign * DB_VALUE(V, j), run_col, n);
                }
#else
                for (long j = j0; j < j1; ++j) {
                    const short2 p = P[j];
                    splat_run(row + (long)p.y * buf_w + p.x, DB_VALUE(V, j), run_col, n);
                }
#endif
                continue;
            }
#endif
#if LAP_GROUP >= 0
            __global pix_t *lap = tile + LAP_GROUP * group_stride + centre;
            n_laplacian += (j1 - j0) * n;
            lap_x0 = min(lap_x0, x - n), lap_x1 = max(lap_x1, x - 1);   // the run: x - n .. x - 1
            lap_y0 = min(lap_y0, y), lap_y1 = max(lap_y1, y);
#if ROTATE
            if (turned) {
                splat_spreadlets_rotated(lap, buf_w, P, V, j0, j1, run_col, n, cs);
                continue;
            }
#endif
            for (long j = j0; j < j1; ++j) {
                const short2 p = P[j];
                splat_run(lap + (long)p.y * buf_w + p.x, DB_VALUE(V, j), run_col, n);
            }
#endif
        }
    }
    out[0] = n_spreadlets;
    out[1] = n_dense;
    out[2] = n_laplacian;   // and the box of its pixels: where the Laplacian plane can be non-zero
    out[3] = lap_x0, out[4] = lap_x1, out[5] = lap_y0, out[6] = lap_y1;
}

// First tile index k whose span [k step, k step + size) contains c, for 0 <= c (spans of
// consecutive tiles overlap when size > step).
inline int first_tile(const int c, const int step, const int size) {
    return c < size ? 0 : (c - size) / step + 1;
}

// Whether tile counts c (splat_tiles' out[]) drew into plane g: a tile without lit pixels drew
// nothing, and a lit one only the planes of the kinds its pixels have (skipping an all-zero plane
// adds no term: the sums are bitwise the same)
inline int drew(__global const long *c, const int g) {
    if (!c[7]) return 0;
    if (g == DENSE_GROUP) return c[1] != 0;
    if (g == LAP_GROUP) return c[2] != 0;
    return c[0] != c[2];   // ROW_GROUP: the spreadlets that are not Laplacian
}

// canvas pixel x of a row of OC floats
inline void store_pixel(__global float *row, const int x, const pix_t v) {
#if OC == 1
    row[x] = v;
#elif OC == 3
    vstore3(v.xyz, x, row);
#else
    vstore4(v, x, row);
#endif
}

// canvas (planes, canvas_h, canvas_w, OC): each canvas pixel is the sum of the pixels of the
// tiles covering it that drew into the plane (drew()), tiles in increasing index order. One work
// item per canvas row; the fixed local size (1) spares PoCL a re-compile per image size.
__kernel void merge_tiles(__global const pix_t *tiles, __global const long *counts, __global float *canvas,
                          const int tiles_x, const int tiles_y, const int tile_w, const int tile_h,
                          const int canvas_w, const int canvas_h) {
    const int cy = get_global_id(0);
    if (cy >= canvas_h) return;
    const int buf_w = tile_w + 2 * PAD, buf_h = tile_h + 2 * PAD;
    const int ty_lo = first_tile(cy, tile_h, buf_h), ty_hi = min(cy / tile_h, tiles_y - 1);
    // canvas planes: the Laplacian (if drawn), then the image: dense plus row planes summed here
    // (in that order, as the host summed them), not downloaded apart and added on the host
    __global float *lap_dst = canvas + (long)cy * canvas_w * OC;
    __global float *img_dst = canvas + ((long)(LAP_GROUP >= 0) * canvas_h + cy) * canvas_w * OC;
#if ROW_GROUP >= 0
#if OC == 1
    double run = 0.0;
#else
    double4 run = (double4)0.0;
#endif
#endif
    for (int x = 0; x < canvas_w; ++x) {
        const int tx_lo = first_tile(x, tile_w, buf_w), tx_hi = min(x / tile_w, tiles_x - 1);
        pix_t img = (pix_t)0.0f;
        for (int g = 0; g < GROUPS; ++g) {
            pix_t acc = (pix_t)0.0f;
            for (int ty = ty_lo; ty <= ty_hi; ++ty) {
                for (int tx = tx_lo; tx <= tx_hi; ++tx) {
                    const long t = (long)ty * tiles_x + tx;
                    if (!drew(counts + 8 * t, g)) continue;   // its plane g is all zero
                    acc += tiles[((t * GROUPS + g) * buf_h + (cy - ty * tile_h)) * buf_w + (x - tx * tile_w)];
                }
            }
#if ROW_GROUP >= 0
            if (g == ROW_GROUP) {   // row differences: the image is their running sum
#if OC == 1
                run += (double)acc;
                acc = (float)run;
#else
                run += convert_double4(acc);
                acc = convert_float4(run);
#endif
            }
#endif
            if (g == LAP_GROUP)
                store_pixel(lap_dst, x, acc);
            else
                img += acc;
        }
        if (GROUPS > (LAP_GROUP >= 0))
            store_pixel(img_dst, x, img);
    }
}
