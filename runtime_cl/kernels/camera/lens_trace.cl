// Exact ray tracing through a thick lens (runtime_cl/camera/lens_trace.py: the same formulas as its
// numpy trace and lab/optics/thick_lens.py). The lens is compiled in (TracedLens.build_options):
//   LENS_N, LENS_CHANNELS        surfaces, channels
//   LENS_CURVATURE, LENS_VERTEX, LENS_APERTURE, LENS_STOP   per surface (1/mm, mm, mm, 1 = stop)
//   LENS_ETA                     n_before / n_after, LENS_CHANNELS rows of LENS_N
//   LENS_SENSOR_Z                the sensor plane (mm)
// z runs from the scene into the camera; the first vertex is at z = 0.

__constant float lens_curvature[LENS_N] = LENS_CURVATURE;
__constant float lens_vertex[LENS_N] = LENS_VERTEX;
__constant float lens_aperture[LENS_N] = LENS_APERTURE;
__constant float lens_stop[LENS_N] = LENS_STOP;
__constant float lens_eta[LENS_CHANNELS * LENS_N] = LENS_ETA;

// Trace *o, *d (origin in front of the first surface, unit direction with d.z > 0) through every
// surface, then (to_sensor) to the sensor plane; 1 if the ray got through.
inline int trace_lens(float3 *o, float3 *d, const int channel, const int to_sensor) {
    float3 p, dir = *d;
    int ok = dir.z > 0.0f;
    float3 pos = *o;
    for (int i = 0; i < LENS_N; ++i) {
        const float c = lens_curvature[i], zv = lens_vertex[i], a = lens_aperture[i];
        p = (float3)(pos.x, pos.y, pos.z - zv);
        float t;
        int hit;
        if (c == 0.0f) {
            t = -p.z / dir.z;
            hit = t >= 0.0f;
        } else {
            // c |p + t d|^2 - 2 (p_z + t d_z) = 0, the root continuous with the flat case
            const float b = c * dot(p, dir) - dir.z;
            const float cc = c * dot(p, p) - 2.0f * p.z;
            const float disc = b * b - c * cc;
            t = cc / (sqrt(fmax(disc, 0.0f)) - b);
            hit = disc >= 0.0f && t >= 0.0f;
        }
        p = p + t * dir;
        ok = ok && hit && (p.x * p.x + p.y * p.y <= a * a);
        pos = (float3)(p.x, p.y, p.z + zv);
        if (lens_stop[i] == 0.0f) {
            const float e = lens_eta[channel * LENS_N + i];
            const float3 n = (float3)(c * p.x, c * p.y, c * p.z - 1.0f);
            const float cos_i = -dot(n, dir);
            const float k = 1.0f - e * e * (1.0f - cos_i * cos_i);
            ok = ok && k >= 0.0f;
            const float f = e * cos_i - sqrt(fmax(k, 0.0f));
            dir = e * dir + f * n;
        }
    }
    if (to_sensor) {
        ok = ok && dir.z > 0.0f;
        pos = pos + ((LENS_SENSOR_Z - pos.z) / dir.z) * dir;
    }
    *o = pos;
    *d = dir;
    return ok;
}

__kernel void trace_lens_rays(__global const float *o, __global const float *d, __global const int *channel,
                         __global float *o_out, __global float *d_out, __global int *ok, const int m,
                         const int to_sensor) {
    const int i = get_global_id(0);
    if (i >= m) return;
    float3 p = vload3(i, o), dir = vload3(i, d);
    ok[i] = trace_lens(&p, &dir, channel[i], to_sensor);
    vstore3(p, i, o_out);
    vstore3(dir, i, d_out);
}
