"""splatlab's OpenCL runtime library: numpy + pyopencl only (never lab, mitsuba or drjit)."""
