"""Poisson integration: from a Laplacian canvas back to the image, one module per integrator.

Importing this package registers every integrator (:mod:`runtime_cl.integrate.registry`), in
listing order: ``exact`` (float64 FFT), ``fft32`` (float32 FFT, the default), ``pyramid``.
"""
from runtime_cl.integrate import fft  # noqa: F401  (registers "exact", "fft32")
from runtime_cl.integrate import pyramid  # noqa: F401  (registers "pyramid")
from runtime_cl.integrate.registry import (DEFAULT_INTEGRATOR, Integrator, get_integrator, integrator_names,
                                           register_integrator)

__all__ = ["DEFAULT_INTEGRATOR", "Integrator", "get_integrator", "integrator_names", "register_integrator"]
