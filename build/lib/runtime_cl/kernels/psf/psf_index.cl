// Cell index per point: the PSF-space forward map on its own (tests, diagnostics).
// Needs psf/psf_space.cl before it.
__kernel void psf_index(__global const float *coords,       // (n, PSF_NS)
                        __global const PSF_REAL *psf_thr,   // PsfSpaceTables.thr
                        __global const int *psf_bucket,     // PsfSpaceTables.bucket
                        __global int *cells,                // (n,)
                        const int n) {
    int i = get_global_id(0);
    if (i >= n) return;
    cells[i] = psf_cell(coords + (long)i * PSF_NS, psf_thr, psf_bucket);
}
