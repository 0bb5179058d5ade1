"""Lens-ray tracing through layered images (LES09, LES10): lens samples, min/max N-buffers, the tracer."""
