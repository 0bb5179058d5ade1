"""The FFT integrators: the exact float64 solve (the default) and its float32 twin."""
from __future__ import annotations

from runtime_cl.integrate.poisson import poisson_integrate
from runtime_cl.integrate.registry import Integrator, register_integrator

__all__ = ["ExactFFT", "FFT32"]


@register_integrator("exact")
class ExactFFT(Integrator):
    """:func:`~runtime_cl.integrate.poisson.poisson_integrate` in float64 on the host."""

    summary = "exact periodic FFT Poisson solve in float64 on the host (default)"

    def __call__(self, laplacian) -> tuple:
        return poisson_integrate(laplacian), {"device_ms": 0.0, "transfer_ms": 0.0}


@register_integrator("fft32")
class FFT32(Integrator):
    """The same solve with float32 FFTs (``precision="float32"``): about 1e-5 of the image's
    largest value off the exact solve, and faster."""

    summary = "the same FFT solve in float32 (~1e-5 relative error, faster)"

    def __call__(self, laplacian) -> tuple:
        return poisson_integrate(laplacian, precision="float32"), {"device_ms": 0.0, "transfer_ms": 0.0}
