"""PSF precompute: ``space`` (nested grid boxes), ``tracer`` (light tracing with pre-filtering),
``models`` (one module per PSF model, registered by name), ``analytic`` (exact disc references),
``benchmark`` (M rays/s). Importing this package loads nothing heavy.
"""
