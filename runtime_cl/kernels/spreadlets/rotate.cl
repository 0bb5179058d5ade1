// Per-pixel PSF rotation (LSR18 section 6: symmetries are applied when splatting). Needed by
// spreadlets/splat.cl and spreadlets/gather.cl when built with ROTATE=1.
//
// Convention: an angle a (radians) turns the stored PSF counter-clockwise as the image is viewed,
// i.e. counter-clockwise from image +x with y up (lab.psf_tracing.models.common). Offsets here are
// in pixel axes (dx right, dy down: rows grow downward), so the turn is
//     dx' =  cos(a) dx + sin(a) dy,      dy' = -sin(a) dx + cos(a) dy.
// Quarter turns are exact: float32 cannot hold pi/2, so an angle within 2^-19 rad (after
// reduction modulo 2 pi) of a multiple of pi/2 uses exact 0 and +-1 -- at most 2^-19 rad off,
// 0.001 px at 500 px from the centre -- and 90 and 180 degree turns move integer offsets to
// integer offsets with no rounding anywhere.
// Build options: DC (database channels) as in spreadlets/splat.cl.

// TO_PIX (a float4 accumulator as the output pixel): prelude/pixels.cl

inline float2 rotation_cs(const float angle) {
    const float a = fmod(angle, 2.0f * M_PI_F);  // exact; |a| < 2 pi keeps the quarter index small
    const float q = rint(a * M_2_PI_F);
    if (fabs(a - q * M_PI_2_F) <= 0x1p-19f) {
        const int k = (int)q & 3;  // two's complement: -1 & 3 = 3, a quarter turn clockwise
        return (float2)(k == 0 ? 1.0f : (k == 2 ? -1.0f : 0.0f), k == 1 ? 1.0f : (k == 3 ? -1.0f : 0.0f));
    }
    float c;
    const float s = sincos(a, &c);
    return (float2)(c, s);
}

// Rounding without builtins: PoCL calls library functions for floor, rint and convert_*_rte,
// which made the turned spreadlet loop about 2x slower; these compile to a few instructions.
// round_px is rint (ties to even) for |v| < 2^22 (adding 1.5 * 2^23 leaves no fraction bits;
// exact IEEE arithmetic, no -cl-fast-relaxed-math); floor_px is exact for |v| < 2^31.
inline int round_px(const float v) { return (int)((v + 0x1.8p23f) - 0x1.8p23f); }
inline int floor_px(const float v) {
    const int i = (int)v;  // truncation towards 0
    return i - (v < (float)i);
}

// The turned offset of (x, y) (pixel axes), unrounded.
inline float2 rotate_xy(const float2 cs, const float x, const float y) {
    return (float2)(cs.x * x + cs.y * y, cs.x * y - cs.y * x);
}

// Dense PSFs (the Splat baseline, fast-tracked cells, the Filter's gather) are turned by inverse
// mapping: destination offset d takes the stored PSF bilinearly interpolated at R^-1 d, and the
// turned PSF is scaled per channel so that it keeps the stored PSF's sum (its energy) exactly.
// Forward mapping (each stored pixel shared bilinearly among the four pixels around R o) keeps
// the energy without scaling, but the turned unit lattice covers the destination pixels
// unevenly: a flat PSF gets a moire of +-10 % and more at 30-45 degrees (bilinear tents summed
// over a rotated lattice), where inverse mapping reproduces it exactly. Quarter turns sample
// integer positions, so they are exact permutations and need no scaling.
//
// Values are float4 whatever DC: (v, v, v, v) for DC = 1, (r, g, b, 0) for DC = 3.

inline float4 psf_tap(__global const float *dv, const int side, const int x, const int y) {
    if (x < 0 || x >= side || y < 0 || y >= side) return (float4)0.0f;
    const long j = (long)y * side + x;
#if DC == 1
    return (float4)(dv[j]);
#else
    return (float4)(dv[3 * j], dv[3 * j + 1], dv[3 * j + 2], LANE3(dv, j));
#endif
}

inline int is_quarter_turn(const float2 cs) { return cs.x == 0.0f || cs.y == 0.0f; }

// Half-width of the square of destination offsets a PSF of radius r turned by cs can reach:
// the stored crop's bilinear support, the open square of half-width r + 1, turned, spans
// less than (r + 1)(|cos| + |sin|) <= (r + 1) sqrt(2) (SpreadletDatabase.rotated_pad holds it).
inline int turned_reach(const int r, const float2 cs) {
    return floor_px((float)(r + 1) * (fabs(cs.x) + fabs(cs.y)));
}

// The turned PSF can be non-zero only where R^-1 d falls inside the stored PSF's non-zero box
// widened by 1 (bilinear support): box = (x_lo, x_hi, y_lo, y_hi), stored offsets, open bounds
// (upload.py dense_boxes; an all-zero PSF has an empty box). turned_cols gives row dy's columns
// [*lo, *hi] of that support, within the reach, one column wider each side against float
// rounding: columns it leaves out hold exact zeros, so a loop over them adds the same non-zero
// terms in the same order as a loop over the whole reach square -- bitwise the same sums -- at
// a fraction of the taps (a motion streak of length 2r and width w: ~(2r + 2)(w + 2) / sin
// instead of (2 reach + 1)^2; 8-30x fewer on the whirl scene's moving pixels).
inline void turned_cols(const float2 cs, const float4 box, const int reach, const int dy, int *lo, int *hi) {
    float a = -(float)reach - 1.0f, b = (float)reach + 1.0f;
    // sx = c dx - s dy in (box.x, box.y); sy = s dx + c dy in (box.z, box.w)
    const float k[2] = {cs.x, cs.y}, off[2] = {-cs.y * dy, cs.x * dy};
    const float blo[2] = {box.x, box.z}, bhi[2] = {box.y, box.w};
    for (int i = 0; i < 2; ++i) {
        if (k[i] == 0.0f) {
            if (!(off[i] > blo[i] && off[i] < bhi[i])) { a = 1.0f; b = 0.0f; }
            continue;
        }
        const float u = (blo[i] - off[i]) / k[i], w = (bhi[i] - off[i]) / k[i];
        a = fmax(a, fmin(u, w));
        b = fmin(b, fmax(u, w));
    }
    *lo = max(-reach, floor_px(a) - 1);
    *hi = min(reach, floor_px(b) + 1);
}

// The open support box of cell's dense PSF (dense_box: (n,) int4 (x0, x1, y0, y1) of its
// non-zero pixels as offsets, x1 < x0 if all zero).
inline float4 support_box(__global const int4 *dense_box, const int cell) {
    const int4 b = dense_box[cell];
    return (float4)((float)b.x - 1.0f, (float)b.y + 1.0f, (float)b.z - 1.0f, (float)b.w + 1.0f);
}

// *v = the turned PSF (unscaled) at destination offset (dx, dy); 0 if R^-1 d lies outside the
// stored crop's bilinear support.
inline int turned_value(__global const float *dv, const int r, const float2 cs, const int dx, const int dy,
                        float4 *v) {
    const float sx = cs.x * dx - cs.y * dy, sy = cs.y * dx + cs.x * dy;  // R^-1 d
    const float edge = (float)(r + 1);
    if (fabs(sx) >= edge || fabs(sy) >= edge) return 0;
    const int ix = floor_px(sx), iy = floor_px(sy);
    const float wx = sx - (float)ix, wy = sy - (float)iy;
    const int side = 2 * r + 1, x = ix + r, y = iy + r;
    if (wx == 0.0f && wy == 0.0f) {  // quarter turns: one tap, the same value as four
        *v = psf_tap(dv, side, x, y);
        return 1;
    }
    *v = psf_tap(dv, side, x, y) * ((1.0f - wx) * (1.0f - wy)) + psf_tap(dv, side, x + 1, y) * (wx * (1.0f - wy))
       + psf_tap(dv, side, x, y + 1) * ((1.0f - wx) * wy) + psf_tap(dv, side, x + 1, y + 1) * (wx * wy);
    return 1;
}

// Per channel: stored sum / turned sum (1 where either is not positive: no energy to keep).
inline float4 energy_scale(const float4 stored, const float4 turned) {
    return select((float4)1.0f, stored / turned, (stored > 0.0f) & (turned > 0.0f));
}

// The stored sum of a cell (dense_sum: (n, DC)) as float4.
inline float4 stored_sum(__global const float *dense_sum, const int cell) {
#if DC == 1
    return (float4)(dense_sum[cell]);
#else
    return (float4)(dense_sum[3 * cell], dense_sum[3 * cell + 1], dense_sum[3 * cell + 2], LANE3(dense_sum, cell));
#endif
}
