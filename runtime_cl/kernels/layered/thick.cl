// Lens rays of a thick lens through layered height fields: built after camera/lens_trace.cl (the
// reversed lens, LENS_* constants) and layered/trace.cl (trace_ray, nbuffer_query, own_colour, hash_u32).
//
// A pixel's sensor point s sends backward rays aimed at points of the exit-pupil box of its
// radius (runtime_cl/camera/exit_pupil.py) through the lens, per channel with that channel's
// indices (chromatic aberration). A ray leaving the lens is a straight line in object space; in the
// pinhole image at the entrance pupil (the labelled pixels' view), parametrised by inverse depth
// w = 1/Z (Z from the pupil), it is again the line q(w) = a + b w:
//     X/Z = t + w (o - Z_o t),   t = d_xy / d_z,   Z_o: the depth of its exit point o,
// so a = centre + F_PX t (where it goes at infinity) and b = F_PX (o - Z_o t) / 1000 (where it
// crosses the pupil plane; w in 1/m): the thin lens's a = p - xi S / F, b = xi S is the paraxial case.
// The layers are searched as for the thin lens (trace.cl). A pixel's colour per channel is the
// cos^4-weighted mean over its rays that hit, which renormalises vignetting as the Mitsuba
// reference sensor does (lab/reference/thick_lens_sensor.py): blocked rays carry no weight.
//
// Constants (-D) besides trace.cl's: NCH (channels = LENS_CHANNELS), MM_PX (sensor mm per pixel),
// F_PX (the pinhole's focal length in pixels), ORIGIN_Z (the sensor in reversed-lens z), LAST_Z
// (the forward lens's last vertex), PUPIL_Z (the entrance pupil), PLANE_GAP, NBOX, INV_STEP (the
// exit-pupil table), TILT_GX, TILT_GY (a tilted sensor's slopes: its z grows by them per mm of sensor
// x and y; 0 untilted).

// One backward ray of sensor point s (mm) through the box sample u in [0, 1)^2 in channel ch, as
// (a, b) with its weight cos^4; false: blocked or totally reflected.
static bool thick_ray(float2 s, float2 u, int ch, global const float4 *boxes, float2 *a, float2 *b, float *weight)
{
    float r = length(s);
    float4 box = boxes[min((int)(r * INV_STEP), NBOX - 1)];
    float bx = box.x + u.x * (box.y - box.x), by = box.z * (2.0f * u.y - 1.0f);
    float cs = r > 0.0f ? s.x / r : 1.0f, sn = r > 0.0f ? s.y / r : 0.0f;
    float dz = TILT_GX * s.x + TILT_GY * s.y;   // a tilted sensor: the point's z beyond the axial plane
    float3 dir = normalize((float3)(cs * bx - sn * by - s.x, sn * bx + cs * by - s.y, PLANE_GAP + dz));
    float c2 = dir.z * dir.z;
    float3 o = (float3)(s.x, s.y, ORIGIN_Z - dz);
    if (!trace_lens(&o, &dir, ch, 0) || !(dir.z > 0.0f))
        return false;
    float zo = PUPIL_Z - (LAST_Z - o.z);     // forward z = LAST_Z - z'; depth from the pupil
    float tx = dir.x / dir.z, ty = dir.y / dir.z;
    // image x runs with lens x, image y against lens y (the sensor sees the scene inverted)
    *a = (float2)(0.5f * W + F_PX * tx, 0.5f * H - F_PX * ty);
    *b = (float2)(F_PX * 1e-3f * (o.x - zo * tx), -F_PX * 1e-3f * (o.y - zo * ty));
    *weight = c2 * c2;
    return true;
}

static float2 pixel_sample(global const float2 *samples, uint o, int j)
{
    int s = (int)o + j;
    return samples[s < NSAMPLES ? s : s - NSAMPLES];
}

#ifdef CONE
// A cone's edge (LES09 4.4) through the real lens: the ray of the neighbouring box sample u + d e
// (d: the samples' spacing, toward the box's middle; the other way if that ray is blocked) as an
// offset (a' - a, b' - b) from the ray (a, b); its spread at the hit depth sizes the cone
// (cone_colour), so the footprint follows spherical aberration, the cat-eye's squeeze and the
// channel's index. Zero when both neighbours are blocked: a point sample.
static float4 neighbour(float2 s, float2 u, float2 e, float spacing, int ch, global const float4 *boxes, float2 a,
                        float2 b)
{
    float2 a2, b2, step = e * (dot(u, e) < 0.5f ? spacing : -spacing);
    float wt;
    if (thick_ray(s, u + step, ch, boxes, &a2, &b2, &wt) || thick_ray(s, u - step, ch, boxes, &a2, &b2, &wt))
        return (float4)(a2 - a, b2 - b);
    return (float4)0.0f;
}
#endif

static float lane(float4 v, int ch)
{
    return ch == 0 ? v.x : (ch == 1 ? v.y : v.z);
}

// Per layer, the inverse depths the pixel's rays can hit (as pixel_ranges in trace.cl), their
// footprint at w in [lo, hi] being [amin + w bmin, amax + w bmax] per axis (w >= 0).
static void thick_ranges(global const float2 *nbuf, global const float2 *range, float2 amin, float2 amax,
                         float2 bmin, float2 bmax, float wmax, float thick, float *wa, float *wb)
{
    for (int k = 0; k < NL; ++k) {
        float2 r = range[k];
        float lo = fmax(0.0f, r.x - thick), hi = fmin(wmax, r.y);
        for (int it = 0; it < PIXEL_ITERS && lo <= hi; ++it) {
            float2 qlo = amin + fmin(bmin * lo, bmin * hi) - MARGIN, qhi = amax + fmax(bmax * lo, bmax * hi) + MARGIN;
            int x0 = clamp((int)floor(qlo.x), 0, W - 1), x1 = clamp((int)floor(qhi.x), 0, W - 1);
            int y0 = clamp((int)floor(qlo.y), 0, H - 1), y1 = clamp((int)floor(qhi.y), 0, H - 1);
            float2 m = nbuffer_query(nbuf, k, x0 / DS, y0 / DS, x1 / DS, y1 / DS);
            lo = fmax(lo, m.x - thick);
            hi = fmin(hi, m.y);
        }
        wa[k] = lo;
        wb[k] = hi;
    }
}

// The sensor point (mm, x flipped: the image is inverted) of image point p (pixels, from the top left).
static float2 sensor_mm(float2 p)
{
    return (float2)(-(p.x - 0.5f * W) * MM_PX, (p.y - 0.5f * H) * MM_PX);
}

// One work item per pixel: NRAYS box samples (per-pixel offsets into the jittered set, LES09 4.5),
// each traced in every channel; with CONE each a cone (cone_colour) whose size the rays of its
// neighbouring samples give, weighted by the fraction it found. out: the channels' weighted means
// (xyz) and the (ray, channel) pairs that hit / NCH (w); stats: pairs that left the image, found
// nothing, were blocked.
kernel void render_thick(global const float *height, global const float4 *colour, global const float2 *nbuf,
                         global const float2 *range, global const float2 *samples, global const float4 *boxes,
                         float wmax, float thick, uint seed, global const float4 *mip, global const int *mip_offset,
                         float spacing, float cone_scale, global float4 *out, global int4 *stats)
{
    int x = get_global_id(0), y = get_global_id(1);
    if (x >= W || y >= H)
        return;
    float2 s = sensor_mm((float2)((float)x + 0.5f, (float)y + 0.5f));
    uint o = hash_u32((uint)(y * W + x) ^ hash_u32(seed)) % NSAMPLES;
    float2 a, b, amin = (float2)(INFINITY), amax = (float2)(-INFINITY), bmin = amin, bmax = amax;
    float weight;
    int passed = 0;
    for (int j = 0; j < NRAYS; ++j)
        for (int ch = 0; ch < NCH; ++ch)
            if (thick_ray(s, pixel_sample(samples, o, j), ch, boxes, &a, &b, &weight)) {
                amin = fmin(amin, a);
                amax = fmax(amax, a);
                bmin = fmin(bmin, b);
                bmax = fmax(bmax, b);
                ++passed;
            }
    float wa[NL], wb[NL];
    if (passed)
        thick_ranges(nbuf, range, amin, amax, bmin, bmax, wmax, thick, wa, wb);
    float sum[NCH], wsum[NCH];
    for (int ch = 0; ch < NCH; ++ch)
        sum[ch] = wsum[ch] = 0.0f;
    int left_n = 0, miss_n = 0, hit_n = 0;
    for (int j = 0; j < NRAYS && passed; ++j)
        for (int ch = 0; ch < NCH; ++ch) {
            float2 u = pixel_sample(samples, o, j);
            if (!thick_ray(s, u, ch, boxes, &a, &b, &weight))
                continue;
            bool left;
            hit_t hit = trace_ray(height, nbuf, wa, wb, a, b, 1.0f / b, wmax, INFINITY, thick, &left);
            if (hit.layer < 0) {
                left_n += left ? 1 : 0;
                miss_n += left ? 0 : 1;
                continue;
            }
#ifdef CONE
            float4 n1 = cone_scale * neighbour(s, u, (float2)(1.0f, 0.0f), spacing, ch, boxes, a, b);
            float4 n2 = cone_scale * neighbour(s, u, (float2)(0.0f, 1.0f), spacing, ch, boxes, a, b);
            float4 cone = cone_colour(height, nbuf, mip, mip_offset, wa, wb, a, b, 1.0f / b, n1, n2, wmax, thick, hit);
            sum[ch] += weight * lane(cone, ch);
            wsum[ch] += weight * cone.w;
#else
            sum[ch] += weight * lane(surface_colour(height, colour, hit.layer, hit.cell, hit.w, a, b, thick), ch);
            wsum[ch] += weight;
#endif
            ++hit_n;
        }
    bool found;   // a channel no ray hit: the nearest layer's own pixel, if any (else 0)
    float4 own = own_colour(height, colour, x, y, &found);
    float res[3] = {own.x, own.y, own.z};
    for (int ch = 0; ch < NCH; ++ch)
        if (wsum[ch] > 0.0f)
            res[ch] = sum[ch] / wsum[ch];
    out[y * W + x] = (float4)(res[0], res[1], res[2], (float)hit_n / NCH);
    stats[y * W + x] = (int4)(left_n, miss_n, NRAYS * NCH - passed, 0);
}

// Tests: the (a, b) and weight of the rays render_thick traces for pixels (px, py) and samples
// u; out = (a.x, a.y, b.x, b.y), weight (0: blocked).
kernel void thick_rays(global const float4 *pixel_u, global const int *channel, global const float4 *boxes, int n,
                       global float4 *out, global float *weight)
{
    int i = get_global_id(0);
    if (i >= n)
        return;
    float4 pu = pixel_u[i];
    float2 s = sensor_mm(pu.xy);
    float2 a, b;
    float wt;
    bool ok = thick_ray(s, pu.zw, channel[i], boxes, &a, &b, &wt);
    out[i] = ok ? (float4)(a, b) : (float4)(0.0f);
    weight[i] = ok ? wt : 0.0f;
}

#ifdef CONE
// Tests: the cone diameter (pixels) at inverse depth w of the rays of pixels (px, py) through box
// samples u (0: blocked, or both neighbours blocked).
kernel void thick_cones(global const float4 *pixel_u, global const int *channel, global const float4 *boxes, int n,
                        float w, float spacing, global float *out)
{
    int i = get_global_id(0);
    if (i >= n)
        return;
    float4 pu = pixel_u[i];
    float2 s = sensor_mm(pu.xy);
    float2 a, b;
    float wt;
    float d = 0.0f;
    if (thick_ray(s, pu.zw, channel[i], boxes, &a, &b, &wt))
        d = cone_diameter(neighbour(s, pu.zw, (float2)(1.0f, 0.0f), spacing, channel[i], boxes, a, b),
                          neighbour(s, pu.zw, (float2)(0.0f, 1.0f), spacing, channel[i], boxes, a, b), w);
    out[i] = d;
}
#endif
