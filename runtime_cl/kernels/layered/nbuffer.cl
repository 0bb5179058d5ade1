// Min/max N-buffers of the layers' inverse depth on the device (runtime_cl/layered/nbuffer.py says
// what they hold; minmax_nbuffer there is the numpy twin the tests hold these kernels to).
// Layout: nbuf[((k * LEVELS + level) * H4 + y) * W4 + x] = (min, max); empty: (+BIG, -BIG).
// Constants (-D): W, H, NL, DS, W4, H4, LEVELS.

#define BIG 1e30f

// Level 0: per DS x DS block of layer k, the min/max of the pixels that hold something (h >= 0).
kernel void nbuffer_base(global const float *height, global float2 *nbuf)
{
    int x = get_global_id(0), y = get_global_id(1), k = get_global_id(2);
    if (x >= W4 || y >= H4)
        return;
    global const float *layer = height + (size_t)k * W * H;
    float lo = BIG, hi = -BIG;
    for (int j = y * DS; j < min(y * DS + DS, H); ++j)
        for (int i = x * DS; i < min(x * DS + DS, W); ++i) {
            float h = layer[j * W + i];
            if (h >= 0.0f) {
                lo = fmin(lo, h);
                hi = fmax(hi, h);
            }
        }
    nbuf[((size_t)k * LEVELS * H4 + y) * W4 + x] = (float2)(lo, hi);
}

// Level lv from lv - 1: the square of side 2^lv at (x, y) is four of side 2^(lv-1), cut at the edge.
kernel void nbuffer_level(global float2 *nbuf, int lv)
{
    int x = get_global_id(0), y = get_global_id(1), k = get_global_id(2);
    if (x >= W4 || y >= H4)
        return;
    int step = 1 << (lv - 1);
    global const float2 *prev = nbuf + ((size_t)k * LEVELS + lv - 1) * H4 * W4;
    float2 r = prev[y * W4 + x];
    int xs = x + step, ys = y + step;
    if (xs < W4) {
        float2 o = prev[y * W4 + xs];
        r = (float2)(fmin(r.x, o.x), fmax(r.y, o.y));
    }
    if (ys < H4) {
        float2 o = prev[ys * W4 + x];
        r = (float2)(fmin(r.x, o.x), fmax(r.y, o.y));
        if (xs < W4) {
            o = prev[ys * W4 + xs];
            r = (float2)(fmin(r.x, o.x), fmax(r.y, o.y));
        }
    }
    nbuf[((size_t)k * LEVELS + lv) * H4 * W4 + y * W4 + x] = r;
}

// Per layer, the range of the whole layer: the top level's first square covers it.
kernel void nbuffer_range(global const float2 *nbuf, global float2 *range)
{
    int k = get_global_id(0);
    if (k < NL)
        range[k] = nbuf[((size_t)k * LEVELS + LEVELS - 1) * H4 * W4];
}
