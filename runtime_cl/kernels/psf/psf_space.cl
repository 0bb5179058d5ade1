// PSF space forward map: physical coordinates -> nested-grid cell (LSR18 section 5.2).
// Mirror of runtime_cl.psf_space.NestedGrid.index; see there for the cell numbering.
//
// The cell depends on the grid coordinates g_d = n s_d^(1/beta_d) only through the integers
// G_d = floor(g_d) (every cell boundary lies at an integer g). pow() costs ~80 ns on PoCL, so
// G_d is found without it: G_d = max{k : s_d >= thr_d[k]}, thr_d[k] = (k/n)^beta_d computed
// by the host, starting from a guess read from a table indexed by the float32 exponent and
// the top PSF_MB_d mantissa bits of s_d (a log-spaced bucket table), then corrected by a few
// exact threshold comparisons. Both tables come from runtime_cl.psf_space_cl.PsfSpaceTables.
//
// Build options:
//   PSF_NS, PSF_N, PSF_LEVELS    coordinates, grid units per dimension, levels
//   PSF_NESTED, PSF_BINS         coordinates on the nested grid; 0, or the bins of a uniform last
//                                coordinate (then cell = bin * PSF_NESTED_SIZE + nested cell)
//   PSF_NESTED_SIZE              cells of the nested grid
//   PSF_REAL                     double if the device has fp64 (then cells match numpy except
//                                within ~1e-12 relative of a cell boundary), else float
//   PSF_LO, PSF_HI               comma lists, one value per coordinate
//   PSF_OCTAVES, PSF_MB          per nested coordinate: bucket octaves below 1 and mantissa bits
//   PSF_THR_OFF, PSF_BUCKET_OFF  per nested coordinate: start of its part of the two tables
//   PSF_LEVEL_OFFSETS            first cell index of each level, PSF_LEVELS + 1 values
#if PSF_REAL_IS_DOUBLE
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
#endif

__constant PSF_REAL psf_lo[PSF_NS] = {PSF_LO};
__constant PSF_REAL psf_hi[PSF_NS] = {PSF_HI};
__constant int psf_octaves[PSF_NESTED] = {PSF_OCTAVES};
__constant int psf_mb[PSF_NESTED] = {PSF_MB};
__constant int psf_thr_off[PSF_NESTED] = {PSF_THR_OFF};
__constant int psf_bucket_off[PSF_NESTED] = {PSF_BUCKET_OFF};
__constant long psf_level_offsets[PSF_LEVELS + 1] = {PSF_LEVEL_OFFSETS};

inline long psf_triangular(long l) { return l * (l + 1) / 2; }

inline long psf_ipow(long b, int e) {
    long r = 1;
    for (int i = 0; i < e; ++i) r *= b;
    return r;
}

// floor(n s^(1/beta)) for dimension d, s in [0, 1]
inline int psf_floor_g(PSF_REAL s, int d, __global const PSF_REAL *thr, __global const int *bucket) {
    __global const PSF_REAL *t = thr + psf_thr_off[d];
    float sf = (float)s;
    int G = 0;
    int e = (int)((as_uint(sf) >> 23) & 0xff) - 127;  // s in [2^e, 2^(e+1)); 0 and denormals -> -127
    if (e >= -psf_octaves[d]) {
        int m = (int)((as_uint(sf) & 0x7fffff) >> (23 - psf_mb[d]));
        G = bucket[psf_bucket_off[d] + ((e + psf_octaves[d]) << psf_mb[d]) + m];
    }
    while (G < PSF_N && s >= t[G + 1]) ++G;  // float rounding of sf may put the guess one off
    while (G > 0 && s < t[G]) --G;
    return G;
}

// Cell index of the PSF coordinates x[0..PSF_NS-1]. The host validates the range; the clamp
// to [0, 1] (which also maps NaN to 0) only keeps memory accesses in bounds.
inline int psf_cell(__global const float *x, __global const PSF_REAL *thr, __global const int *bucket) {
    long G[PSF_NESTED];
    long gmin = PSF_N;
    for (int d = 0; d < PSF_NESTED; ++d) {
        PSF_REAL s = ((PSF_REAL)x[d] - psf_lo[d]) / (psf_hi[d] - psf_lo[d]);
        s = fmin(fmax(s, (PSF_REAL)0), (PSF_REAL)1);
        G[d] = psf_floor_g(s, d, thr, bucket);
        gmin = min(gmin, G[d]);
    }
    // level: triangular root of gmin (an integer, so the float estimate is fixed exactly)
    long l = (long)((sqrt(8.0f * (float)gmin + 1.0f) - 1.0f) * 0.5f);
    while (psf_triangular(l + 1) <= gmin) ++l;
    while (l > 0 && psf_triangular(l) > gmin) --l;
    l = min(l, (long)(PSF_LEVELS - 1));
    long t0 = psf_triangular(l);
    long w = l + 1;
    long kmax = (PSF_N - t0 + w - 1) / w;
    long k[PSF_NESTED];
    int j = -1;
    for (int d = 0; d < PSF_NESTED; ++d) {
        long kd = G[d] >= t0 ? (G[d] - t0) / w : -1;  // floor division; clamped next
        k[d] = clamp(kd, (long)0, kmax - 1);
        if (j < 0 && k[d] == 0) j = d;
    }
    if (j < 0) j = 0;  // unreachable by construction; numpy's argmax gives 0 too
    long index = 0;
    for (int jj = 0; jj < j; ++jj) index += psf_ipow(kmax - 1, jj) * psf_ipow(kmax, PSF_NESTED - 1 - jj);
    long rank = 0;
    for (int d = 0; d < PSF_NESTED; ++d) {
        if (d == j) continue;
        rank = d < j ? rank * (kmax - 1) + (k[d] - 1) : rank * kmax + k[d];
    }
    long cell = psf_level_offsets[l] + index + rank;
#if PSF_BINS > 0
    // the uniform last coordinate: floor(bins s), as numpy computes it (same s, same precision)
    PSF_REAL s = ((PSF_REAL)x[PSF_NS - 1] - psf_lo[PSF_NS - 1]) / (psf_hi[PSF_NS - 1] - psf_lo[PSF_NS - 1]);
    s = fmin(fmax(s, (PSF_REAL)0), (PSF_REAL)1);
    cell += (long)min((int)floor(s * PSF_BINS), PSF_BINS - 1) * PSF_NESTED_SIZE;
#endif
    return (int)cell;
}
