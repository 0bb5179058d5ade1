// Lens rays through layered height fields (LES09 4.3, LES10 3) for a thin lens.
//
// A lens ray of pixel centre p through the unit-disc lens sample xi is, in the pinhole image of
// the lens centre and parametrised by inverse depth w = 1/z, the straight line
//     q(w) = a + b w,   a = p - xi S / F,   b = xi S
// (S: CoC scale in px per dioptre, F: focus distance), so q(1/F) = p and q moves by the CoC
// |C(z)| = S |1/F - 1/z| from p at depth z.
//
// Layer k's pixel c is a surfel: its cell [cx, cx+1) x [cy, cy+1) at inverse depth h (0 at
// infinity, < 0 empty), solid over the slab h - THICK <= w <= h. A ray hits it where q(w) lies in
// the cell and w in the slab. The ray's hit is the largest such w over all layers (the nearest
// surface), ties to the lower layer. A slab, not a solid height field: a ray that passes beside
// a near surfel and then behind it goes on (what the pinhole view hides, the peeled layers hold);
// THICK = t_px / S makes the slab t_px pixels of ray travel deep, so neighbours of a continuous
// surface whose CoCs differ by less than that leave no gap.
//
// Per layer the search runs on the part of the ray inside the image, in front of the best hit so
// far, clamped by min/max inverse depths (LES10): first PIXEL_ITERS times for all rays of a pixel
// at once (their footprint is the CoC), then CLAMP_ITERS times per ray: the footprint of the segment
// (the bounding box of its end points) is looked up in an N-buffer over the layer down-sampled by
// DS (four overlapping squares, Decoret 2005), and the segment cut to [min - THICK, max]. An
// empty footprint culls the layer. The rest is walked cell by cell (exact 2D DDA, near to far).
//
// Constants (-D): W, H, NL (layers), NRAYS, NSAMPLES (lens samples, 2 NRAYS), DS, W4, H4 (the
// down-sampled grid), LEVELS (N-buffer levels), CLAMP_ITERS, PIXEL_ITERS; INTERPOLATE_HIDDEN (1: read
// surfels hidden behind a nearer layer bilinearly, see surface_colour); FALSE_POSITION and FP_ITERS for LES09's
// search instead of the exact walk; CONE, CONE_STEPS and MIPS for approximate cone tracing.

#define MARGIN 0.01f   // pixels added around footprints: float rounding must not drop a cell

typedef struct {
    float w;      // inverse depth of the hit, -1: none
    int layer;    // -1: none
    int cell;     // y W + x of the hit cell
} hit_t;

// (min h, max h) of layer k over down-sampled cells [cx0, cx1] x [cy0, cy1] (conservative).
static float2 nbuffer_query(global const float2 *nbuf, int k, int cx0, int cy0, int cx1, int cy1)
{
    int n = max(cx1 - cx0, cy1 - cy0) + 1;
    int lv = min(31 - (int)clz(n), LEVELS - 1);
    int size = 1 << lv;
    int xa = cx0, xb = max(cx1 - size + 1, 0), ya = cy0, yb = max(cy1 - size + 1, 0);
    global const float2 *level = nbuf + ((size_t)k * LEVELS + lv) * (W4 * H4);
    float2 r0 = level[ya * W4 + xa], r1 = level[ya * W4 + xb];
    float2 r2 = level[yb * W4 + xa], r3 = level[yb * W4 + xb];
    return (float2)(fmin(fmin(r0.x, r1.x), fmin(r2.x, r3.x)), fmax(fmax(r0.y, r1.y), fmax(r2.y, r3.y)));
}

// Cut [*wa, *wb] of layer k to the min/max inverse depths under its footprint; false: no hit.
static bool clamp_segment(global const float2 *nbuf, int k, float2 a, float2 b, float thick,
                          float *wa, float *wb)
{
    for (int it = 0; it < CLAMP_ITERS; ++it) {
        float2 qa = a + b * *wa, qb = a + b * *wb;
        int x0 = clamp((int)floor(fmin(qa.x, qb.x) - MARGIN), 0, W - 1);
        int x1 = clamp((int)floor(fmax(qa.x, qb.x) + MARGIN), 0, W - 1);
        int y0 = clamp((int)floor(fmin(qa.y, qb.y) - MARGIN), 0, H - 1);
        int y1 = clamp((int)floor(fmax(qa.y, qb.y) + MARGIN), 0, H - 1);
        float2 m = nbuffer_query(nbuf, k, x0 / DS, y0 / DS, x1 / DS, y1 / DS);
        *wa = fmax(*wa, m.x - thick);
        *wb = fmin(*wb, m.y);
        if (*wa > *wb)
            return false;
        if (x1 - x0 < DS && y1 - y0 < DS)
            break;   // one or two down-sampled cells: the walk is as cheap as another look-up
    }
    return true;
}

// Walk layer k's cells under q(w) for w from wb down to wa; the first surfel slab hit with
// w > best->w becomes the best hit. Cell boundaries are crossed at w = (edge - a) / b, computed
// from the edge itself rather than accumulated, so where a ray enters a cell does not depend on
// where the walk started: a hit at a cell's entry ties exactly across layers (the lower wins).
static void walk_layer(global const float *height, int k, float2 a, float2 b, float2 ib, float wa, float wb,
                       float thick, hit_t *best)
{
    float2 q0 = a + b * wb;
    int ix = clamp((int)floor(q0.x), 0, W - 1), iy = clamp((int)floor(q0.y), 0, H - 1);
    int sx = b.x > 0.0f ? -1 : 1, sy = b.y > 0.0f ? -1 : 1;   // q moves against b as w falls
    float w_enter = wb, ibx = ib.x, iby = ib.y;   // 1 / b (inf for b = 0: never crossed)
    global const float *layer = height + (size_t)k * W * H;
    for (;;) {
        float wx = b.x != 0.0f ? ((float)(sx < 0 ? ix : ix + 1) - a.x) * ibx : -INFINITY;
        float wy = b.y != 0.0f ? ((float)(sy < 0 ? iy : iy + 1) - a.y) * iby : -INFINITY;
        float w_exit = fmax(fmax(wx, wy), wa);
        float h = layer[iy * W + ix];
        if (h >= 0.0f) {
            float whi = fmin(h, w_enter), wlo = fmax(h - thick, w_exit);
            if (wlo <= whi && whi > best->w) {
                best->w = whi;
                best->layer = k;
                best->cell = iy * W + ix;
                return;
            }
        }
        if (w_exit <= wa)
            return;
        if (wx >= wy)
            ix += sx;
        else
            iy += sy;
        w_enter = w_exit;
        if (ix < 0 || ix >= W || iy < 0 || iy >= H)
            return;
    }
}

#ifdef FALSE_POSITION
#define BISECT 8
// LES09's search instead of the walk: the layer as a continuous height field along the segment,
// f(w) = w - h(q(w)) (> 0 in front of the surface; an empty pixel is no surface). Starting from
// the segment's ends, FP_ITERS steps of the method of false position: intersect the ray with the
// line through f at both ends, keep the half that still brackets the crossing. The hit is the
// point found just behind the surface, in its cell, if within the slab; a crossing of a
// discontinuity (a silhouette's wall) is then no hit. Approximate: a thin feature between the
// samples can be missed, which the exact walk never does.
static float fp_f(global const float *layer, float2 a, float2 b, float w, int *cell)
{
    float2 q = a + b * w;
    int x = clamp((int)floor(q.x), 0, W - 1), y = clamp((int)floor(q.y), 0, H - 1);
    float h = layer[y * W + x];
    *cell = y * W + x;
    return h >= 0.0f ? w - h : INFINITY;
}

// One step of the bracket [n, f] around the crossing: the sample at wi replaces the far end if it
// lies behind the surface (f <= 0), else the near end.
static void bracket(global const float *layer, float2 a, float2 b, float wi, float *n, float *fn, float *f,
                    float *ff, int *cf)
{
    int ci;
    float fi = fp_f(layer, a, b, wi, &ci);
    if (fi <= 0.0f) {
        *f = wi;
        *ff = fi;
        *cf = ci;
    } else {
        *n = wi;
        *fn = fi;
    }
}

static void search_layer(global const float *height, int k, float2 a, float2 b, float2 ib, float wa, float wb,
                         float thick, hit_t *best)
{
    global const float *layer = height + (size_t)k * W * H;
    int cn, cf;
    float n = wb, f = wa;
    float fn = fp_f(layer, a, b, n, &cn), ff = fp_f(layer, a, b, f, &cf);
    if (fn <= 0.0f) {            // behind a surface from the start: the near end is the hit
        f = n;
        ff = fn;
        cf = cn;
    } else if (ff > 0.0f) {
        return;                  // in front at both ends: no crossing found
    } else {
        for (int it = 0; it < FP_ITERS; ++it)
            bracket(layer, a, b, isinf(fn) ? 0.5f * (n + f) : n - fn * (n - f) / (fn - ff), &n, &fn, &f, &ff, &cf);
        for (int it = 0; it < BISECT && ff < -thick; ++it)   // LES09: a binary search finishes
            bracket(layer, a, b, 0.5f * (n + f), &n, &fn, &f, &ff, &cf);
    }
    if (ff >= -thick && f > best->w) {
        best->w = f;
        best->layer = k;
        best->cell = cf;
    }
}
#define SEARCH_LAYER search_layer
#else
#define SEARCH_LAYER walk_layer
#endif

// The w-range of q(w) = a + b w inside [0, W) x [0, H), within [lo, hi]; false if none.
static bool clip_to_image(float2 a, float2 b, float2 ib, float *lo, float *hi)
{
    float2 size = (float2)(W, H);
    for (int i = 0; i < 2; ++i) {
        float ai = i ? a.y : a.x, bi = i ? b.y : b.x, ibi = i ? ib.y : ib.x, si = i ? size.y : size.x;
        if (bi == 0.0f) {
            if (ai < 0.0f || ai >= si)
                return false;
            continue;
        }
        float w1 = -ai * ibi, w2 = (si - ai) * ibi;
        *lo = fmax(*lo, fmin(w1, w2));
        *hi = fmin(*hi, fmax(w1, w2));
    }
    return *lo <= *hi;
}

// The nearest surfel hit of the ray (a, b) over every layer, each searched within [wa[k], wb[k]]
// (wa > wb: skip the layer) and below wcap; ib = 1 / b per lane (inf where b is 0), so a ray
// divides once, not per layer and image edge; *left: part of [0, wmax] is off the image.
static hit_t trace_ray(global const float *height, global const float2 *nbuf, const float *wa0, const float *wb0,
                       float2 a, float2 b, float2 ib, float wmax, float wcap, float thick, bool *left)
{
    hit_t best = {-1.0f, -1, -1};
    float lo = 0.0f, hi = wmax;
    bool inside = clip_to_image(a, b, ib, &lo, &hi);
    *left = !inside || lo > 0.0f || hi < wmax;
    if (!inside)
        return best;
    for (int k = 0; k < NL; ++k) {
        float wa = fmax(fmax(lo, wa0[k]), best.w), wb = fmin(fmin(hi, wb0[k]), wcap);
        if (wa > wb)
            continue;   // an empty layer, or nothing of it in front of the best hit
        if (!clamp_segment(nbuf, k, a, b, thick, &wa, &wb))
            continue;
        SEARCH_LAYER(height, k, a, b, ib, wa, wb, thick, &best);
    }
    return best;
}

// Per layer, the inverse depths any lens ray of pixel p can hit (LES10: one footprint bounds all
// of a pixel's rays: at w they lie within S |w - 1/F| of p, the CoC, largest at an end of the
// segment); wa > wb where none can. Returns the largest wb of the layers behind the first (-1: none
// can be hit): a layer-0 hit at w >= it is the ray's hit (render's first-cell test).
static float pixel_ranges(global const float2 *nbuf, global const float2 *range, float2 p, float coc_scale,
                          float inv_focus, float wmax, float thick, float *wa, float *wb)
{
    float front = -1.0f;   // the nearest inverse depth a layer behind the first can be hit at
    for (int k = 0; k < NL; ++k) {
        float2 r = range[k];
        float lo = fmax(0.0f, r.x - thick), hi = fmin(wmax, r.y);
        for (int it = 0; it < PIXEL_ITERS && lo <= hi; ++it) {
            float reach = coc_scale * fmax(fabs(lo - inv_focus), fabs(hi - inv_focus)) + MARGIN;
            int x0 = clamp((int)floor(p.x - reach), 0, W - 1), x1 = clamp((int)floor(p.x + reach), 0, W - 1);
            int y0 = clamp((int)floor(p.y - reach), 0, H - 1), y1 = clamp((int)floor(p.y + reach), 0, H - 1);
            float2 m = nbuffer_query(nbuf, k, x0 / DS, y0 / DS, x1 / DS, y1 / DS);
            lo = fmax(lo, m.x - thick);
            hi = fmin(hi, m.y);
        }
        wa[k] = lo;
        wb[k] = hi;
        if (k > 0 && lo <= hi)
            front = fmax(front, hi);
    }
    return front;
}

// The colour of the nearest layer that holds something at pixel (x, y); *found: one does.
static float4 own_colour(global const float *height, global const float4 *colour, int x, int y, bool *found)
{
    for (int k = 0; k < NL; ++k)
        if (height[(size_t)k * W * H + y * W + x] >= 0.0f) {
            *found = true;
            return colour[(size_t)k * W * H + y * W + x];
        }
    *found = false;
    return (float4)0.0f;
}

// The colour of layer k's surface where the ray (a, b) hits it at inverse depth w, cell `cell`. A
// surfel the pinhole view sees (no nearer layer holds its cell) is the input's own pixel: read by
// cell, so in-focus detail stays as sharp as the input. A surfel hidden behind a nearer layer's
// pixel (a peeled one) is read bilinearly between the centres of the four cells around q(w), over
// those of the same surface (same layer, inverse depth within thick of the hit), renormalised:
// lens rays reach it at sub-pixel offsets past a defocused occluder, and reading the whole cell
// passed the peeled layer's per-pixel grain (it is peeled at fewer samples) to the image unfiltered.
static float4 surface_colour(global const float *height, global const float4 *colour, int k, int cell, float w,
                             float2 a, float2 b, float thick)
{
    size_t base = (size_t)k * W * H;
    bool hidden = false;
    for (int n = 0; n < k && INTERPOLATE_HIDDEN; ++n)
        hidden = hidden || height[(size_t)n * W * H + cell] >= 0.0f;
    if (!hidden)
        return colour[base + cell];
    float2 q = a + b * w - 0.5f;
    int x0 = (int)floor(q.x), y0 = (int)floor(q.y);
    float fx = q.x - (float)x0, fy = q.y - (float)y0;
    float h0 = height[base + cell];
    float4 sum = (float4)0.0f;
    float wsum = 0.0f;
    for (int j = 0; j < 4; ++j) {
        int x = x0 + (j & 1), y = y0 + (j >> 1);
        if (x < 0 || x >= W || y < 0 || y >= H)
            continue;
        float h = height[base + y * W + x];
        if (!(fabs(h - h0) <= thick) || h < 0.0f)
            continue;   // another surface (a silhouette) or nothing
        float wt = ((j & 1) ? fx : 1.0f - fx) * ((j >> 1) ? fy : 1.0f - fy);
        sum += wt * colour[base + y * W + x];
        wsum += wt;
    }
    return wsum > 0.0f ? sum / wsum : colour[base + cell];
}

#ifdef CONE
// The diameter of a ray's cone at inverse depth w: sqrt of the area |d1 x d2| its lens sample's
// cell spans there, d_i(w) = n_i.xy + n_i.zw w being where the neighbouring samples' rays are
// relative to it (the same lines q = a + b w, differenced). Thin lens: lambda S |w - 1/F|.
static float cone_diameter(float4 n1, float4 n2, float w)
{
    float2 d1 = n1.xy + n1.zw * w, d2 = n2.xy + n2.zw * w;
    return sqrt(fabs(d1.x * d2.y - d1.y * d2.x));
}

// Layer k's colour + coverage mipmap at level lv, bilinear around image point q (pixels; clamped
// to the image's texels).
static float4 mip_bilinear(global const float4 *mip, global const int *mip_offset, int k, int lv, float2 q)
{
    int wl = (W + (1 << lv) - 1) >> lv, hl = (H + (1 << lv) - 1) >> lv;
    float2 f = q / (float)(1 << lv) - 0.5f, i = floor(f), t = f - i;
    int x0 = clamp((int)i.x, 0, wl - 1), x1 = clamp((int)i.x + 1, 0, wl - 1);
    int y0 = clamp((int)i.y, 0, hl - 1), y1 = clamp((int)i.y + 1, 0, hl - 1);
    global const float4 *m = mip + mip_offset[k * MIPS + lv];
    return mix(mix(m[y0 * wl + x0], m[y0 * wl + x1], t.x), mix(m[y1 * wl + x0], m[y1 * wl + x1], t.x), t.y);
}

// LES09 4.4 from a ray's first hit: at a hit the layer's colour + coverage mipmap is read over the
// cone's window, centred on the hit point (trilinear: the level of the diameter, bilinear in
// each level but 0, which is the hit cell; the window neither snaps to the mip's blocks nor jumps
// between levels); the
// covered fraction v adds its mean colour, the rest (1 - v) goes on behind the surfel's slab, up
// to CONE_STEPS hits. Returns the colour found (xyz) and the fraction of the cone that found it
// (w): the ray's weight.
static float4 cone_colour(global const float *height, global const float2 *nbuf, global const float4 *mip,
                          global const int *mip_offset, const float *wa, const float *wb, float2 a, float2 b,
                          float2 ib, float4 n1, float4 n2, float wmax, float thick, hit_t hit)
{
    float4 sum = (float4)0.0f;
    float through = 1.0f;
    bool left;
    for (int step = 0; step < CONE_STEPS; ++step) {
        float diameter = cone_diameter(n1, n2, hit.w);
        // a 2^l box (mip level l) under a bilinear tent of 2^l has the spread (std 0.5 2^l) of a
        // window 1.73 2^l wide: level log2(diameter / 1.73) reads the cone's window
        float level = clamp(log2(diameter * 0.577f), 0.0f, (float)(MIPS - 1));
        int l0 = min((int)level, MIPS - 2 < 0 ? 0 : MIPS - 2);
        float2 q = a + b * hit.w;
        // level 0: the hit cell itself (a cone under a pixel reads what a point ray reads)
        float4 m = l0 ? mip_bilinear(mip, mip_offset, hit.layer, l0, q) : mip[mip_offset[hit.layer * MIPS] + hit.cell];
        if (MIPS > 1 && level > (float)l0)
            m = mix(m, mip_bilinear(mip, mip_offset, hit.layer, l0 + 1, q), level - (float)l0);
        sum += through * (float4)(m.x, m.y, m.z, 0.0f);
        through *= 1.0f - m.w;
        if (through < 0.01f)
            break;
        float cap = height[(size_t)hit.layer * W * H + hit.cell] - thick * 1.0001f - 1e-7f;
        hit = trace_ray(height, nbuf, wa, wb, a, b, ib, wmax, cap, thick, &left);
        if (hit.layer < 0)
            break;
    }
    sum.w = 1.0f - through;
    return sum;
}
#endif

static uint hash_u32(uint x)
{
    x ^= x >> 16;
    x *= 0x7feb352dU;
    x ^= x >> 15;
    x *= 0x846ca68bU;
    x ^= x >> 16;
    return x;
}

// One work item per pixel: NRAYS lens rays, samples (o + j) mod NSAMPLES of the jittered set with a
// per-pixel offset o (LES09 4.5). out: mean colour of the rays that hit (xyz), rays that hit (w);
// stats: rays that left the image, rays that found nothing (holes).
//
// With CONE (LES09 4.4), a ray is a cone of diameter lambda |C(w)| (lambda: the lens samples'
// spacing on the unit disc), traced by cone_colour; a ray's weight is the fraction it found.
kernel void render(global const float *height, global const float4 *colour, global const float2 *nbuf,
                   global const float2 *range, global const float4 *rays, float coc_scale,
                   global const float *inv_focus_map, float wmax, float thick, uint seed, global const float4 *mip,
                   global const int *mip_offset, float lambda, global float4 *out, global int2 *stats)
{
    int x = get_global_id(0), y = get_global_id(1);
    if (x >= W || y >= H)
        return;
    float inv_focus = inv_focus_map[y * W + x];   // 1/F, or the pixel's own on a tilted/expressive focal surface
    float2 p = (float2)(x + 0.5f, y + 0.5f);
    uint o = hash_u32((uint)(y * W + x) ^ hash_u32(seed)) % NSAMPLES;
    float4 sum = (float4)0.0f;
    float weight = 0.0f;
    int left_n = 0, miss_n = 0;
    float wa[NL], wb[NL];
    float front = pixel_ranges(nbuf, range, p, coc_scale, inv_focus, wmax, thick, wa, wb);
    for (int j = 0; j < NRAYS; ++j) {
        int s = (int)o + j;
        float4 r = rays[s < NSAMPLES ? s : s - NSAMPLES];   // b = xi S and 1 / b, from the host
        float2 b = r.xy, ib = r.zw;
        float2 a = p - b * inv_focus;
#if !defined(CONE) && !defined(FALSE_POSITION)
        // Most rays hit layer 0 in the first cell the walk would visit, where its segment starts
        // (wb[0]): that step of walk_layer, with the same arithmetic, then nothing else when no
        // later layer can be hit in front of it (w >= front: a tie goes to layer 0 anyway); any
        // other ray is traced in full (the walk repeats the step). Half the time on the foreground scene.
        if (wa[0] <= wb[0]) {
            float2 q = a + b * wb[0];
            if (q.x >= 0.0f && q.x < (float)W && q.y >= 0.0f && q.y < (float)H) {
                int ix = (int)floor(q.x), iy = (int)floor(q.y), cell = iy * W + ix;
                float wx = b.x != 0.0f ? ((float)(b.x > 0.0f ? ix : ix + 1) - a.x) * ib.x : -INFINITY;
                float wy = b.y != 0.0f ? ((float)(b.y > 0.0f ? iy : iy + 1) - a.y) * ib.y : -INFINITY;
                float h = height[cell];
                if (h >= 0.0f && h <= wb[0] && h >= fmax(fmax(wx, wy), wa[0]) && h >= front) {
                    sum += surface_colour(height, colour, 0, cell, h, a, b, thick);
                    weight += 1.0f;
                    continue;
                }
            }
        }
#endif
        bool left;
        hit_t hit = trace_ray(height, nbuf, wa, wb, a, b, ib, wmax, INFINITY, thick, &left);
        if (hit.layer < 0) {
            left_n += left ? 1 : 0;
            miss_n += left ? 0 : 1;
            continue;
        }
#ifdef CONE
        // the neighbouring lens samples xi + lambda e_x, xi + lambda e_y: offsets lambda S (w - 1/F) e
        float sl = lambda * coc_scale;
        float4 cone = cone_colour(height, nbuf, mip, mip_offset, wa, wb, a, b, ib, (float4)(-sl * inv_focus, 0.0f, sl, 0.0f),
                                  (float4)(0.0f, -sl * inv_focus, 0.0f, sl), wmax, thick, hit);
        sum += (float4)(cone.xyz, 0.0f);
        weight += cone.w;
#else
        sum += surface_colour(height, colour, hit.layer, hit.cell, hit.w, a, b, thick);
        weight += 1.0f;
#endif
    }
    float hits = (float)(NRAYS - left_n - miss_n);
    if (weight > 0.0f) {
        sum /= weight;
    } else if (hits == 0.0f) {   // no ray hit: the nearest layer's own pixel, if any
        bool found;
        float4 own = own_colour(height, colour, x, y, &found);
        if (found) {
            sum = own;
            hits = -1.0f;
        }
    }
    sum.w = hits;
    out[y * W + x] = sum;
    stats[y * W + x] = (int2)(left_n, miss_n);
}

// Tests and tools: trace explicit rays (a.x, a.y, b.x, b.y); out = (w, layer, cell, left).
kernel void trace_rays(global const float *height, global const float2 *nbuf, global const float2 *range,
                       global const float4 *rays, int n, float wmax, float thick, global float4 *out)
{
    int i = get_global_id(0);
    if (i >= n)
        return;
    float4 r = rays[i];
    float wa[NL], wb[NL];
    for (int k = 0; k < NL; ++k) {
        wa[k] = range[k].x - thick;
        wb[k] = range[k].y;
    }
    bool left;
    hit_t hit = trace_ray(height, nbuf, wa, wb, r.xy, r.zw, 1.0f / r.zw, wmax, INFINITY, thick, &left);
    out[i] = (float4)(hit.w, (float)hit.layer, (float)hit.cell, left ? 1.0f : 0.0f);
}
