// Shared by polygon/splat.cl and polygon/baselines.cl (so their results are bit-identical):
// the radius-table entry of a pixel and its fixed-point colour.
#pragma OPENCL EXTENSION cl_khr_fp64 : enable

// Entry of radius r: breaks[e] <= r < breaks[e + 1]. `bucket[i]` is the entry of radius
// i / BUCKETS, so a few steps forward from it find the entry.
inline int find_entry(__global const float *breaks, int n, __global const int *bucket, float r) {
    int e = bucket[(int)(r * BUCKETS)];
    while (e + 1 < n && breaks[e + 1] <= r) ++e;
    return e;
}

// q[c] = rint(colour * unit[entry, c]) (one double product per channel); 0 when all are zero.
inline int quantise(__global const float *image, __global const double *unit, const size_t p,
                    const int e, ulong *q) {
    int any = 0;
    for (int c = 0; c < NC; ++c) {
        const long v = convert_long_rte((double)image[p * NC + c] * unit[e * NC + c]);
        q[c] = (ulong)v;
        any |= v != 0;
    }
    return any;
}
