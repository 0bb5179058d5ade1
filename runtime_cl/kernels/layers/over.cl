// One depth layer composited "over" the layers behind it, with the re-weighting of
// runtime_cl/layers/composite.py, in one pass over the layer's box (NC colour channels), a pixel
// per work item, work-groups of GROUP pixels along a row (PoCL vectorises consecutive work items:
// consecutive pixels). Each operation is the float32 one numpy did there, in the same order, and
// contraction into fused multiply-adds is off, so the image is the same to the last bit.
#pragma OPENCL FP_CONTRACT OFF

__kernel __attribute__((reqd_work_group_size(GROUP, 1, 1)))
void over_layer(__global const float *layer,   // (BH, BW, NC + 1) colour, alpha
                __global const float *blurred, // (RH, RW, K) the region's blurs: the nearer
                                               // layers' coverage (if has_hidden), then the
                                               // layer's own sites (if has_own); or unused
                __global float *out,           // (H, W, NC) composite so far, in place
                __global float *sums,          // (BH, groups, 2) per work-group: covered, total
                const int W, const int r0, const int c0, const int BW,
                const int RW, const int oy, const int ox,   // the box at (oy, ox) of the region
                const int has_hidden, const int has_own, const float min_known) {
    __local float covered[GROUP], total[GROUP];
    const int x = get_global_id(0), y = get_global_id(1), l = get_local_id(0);
    float cov = 0.0f, tot = 0.0f;
    if (x < BW) {
        __global const float *px = layer + ((long)y * BW + x) * (NC + 1);
        const long f = (long)(r0 + y) * W + c0 + x;
        const int k = has_hidden + has_own;
        __global const float *b = blurred + ((long)(oy + y) * RW + ox + x) * k;
        const float alpha = px[NC];
        const float known = has_hidden ? 1.0f - b[0] : 1.0f;
        const float weight = 1.0f / clamp(fmax(known, alpha), min_known, 1.0f);
        float opacity = fmin(alpha * weight, 1.0f);
        cov = opacity;
        tot = fmin(alpha, 1.0f);
        if (has_own)
            opacity = fmax(opacity, fmin(b[k - 1] / clamp(known, min_known, 1.0f), 1.0f));
        const float keep = 1.0f - opacity;
        __global float *o = out + f * NC;
        for (int c = 0; c < NC; ++c) {
            const float kept = o[c] * keep;
            const float added = px[c] * weight;
            o[c] = kept + added;
        }
    }
    covered[l] = cov;
    total[l] = tot;
    barrier(CLK_LOCAL_MEM_FENCE);   // one barrier: a tree of them cost as much as the rest
    if (l == 0) {
        const long g = ((long)y * get_num_groups(0) + get_group_id(0)) * 2;
        float c = 0.0f, t = 0.0f;
        for (int i = 0; i < GROUP; ++i) {
            c += covered[i];
            t += total[i];
        }
        sums[g] = c;
        sums[g + 1] = t;
    }
}
