"""Light-tracing throughput in M rays/s (LSR18's GPU pace: 700 M rays per PSF in ~20 s = 35 M/s).

Usage: ``python -m lab.bench.tracing`` prints the figure for SimpleLens at its defaults.
"""
from __future__ import annotations

import platform
import sys
from dataclasses import dataclass

import drjit as dr

from lab.errors import UserError
from lab.psf_tracing.models.base import PSFModel

__all__ = ["Throughput", "measure_throughput"]


@dataclass(frozen=True)
class Throughput:
    """Best-of-``repeats`` tracing speed of one model and cell (kernels compiled beforehand)."""

    model: str
    cell: int
    n_rays: int
    rays_per_launch: int
    resolution: int
    mrays_per_second: float
    seconds: float
    machine: str

    def to_json(self) -> dict:
        return dict(self.__dict__)


def measure_throughput(model: PSFModel, cell: int | None = None, n_rays: int | None = None,
                       repeats: int = 3) -> Throughput:
    """Time ``model`` tracing ``n_rays`` rays into ``cell`` and report M rays/s.

    Parameters
    ----------
    model : PSFModel
        A configured model; its ``rays_per_launch`` and ``psf_resolution`` are used.
    cell : int, optional
        The cell to trace (default: the last, largest one, whose PSF touches the most pixels).
    n_rays : int, optional
        Rays per timed trace (default: the config's ``rays_per_psf``).
    repeats : int, default 3
        Timed traces after one untimed warm-up (which compiles the kernels); the best counts,
        as other processes share the cores.

    Returns
    -------
    Throughput
        The best rate and the settings it was measured with. Timing is synchronised
        (``dr.sync_thread``) inside the tracer, so asynchronous launches are included.
    """
    if not (isinstance(repeats, int) and repeats >= 1):
        raise UserError(f"repeats = {repeats!r}: must be an integer >= 1")
    cell = model.grid.size - 1 if cell is None else cell
    n = model.config.rays_per_psf if n_rays is None else n_rays
    model.trace_cell(cell, n_rays=min(n, model.config.rays_per_launch))  # warm-up: compile
    dr.sync_thread()
    best = min(model.trace_cell(cell, n_rays=n, seed=k + 1).seconds for k in range(repeats))
    return Throughput(model.name, int(cell), int(n), int(model.config.rays_per_launch),
                      int(model.resolution), n / best / 1e6, best, platform.processor() or platform.machine())


def main(argv=None) -> int:
    from lab.psf_tracing.models import load_model

    model = load_model("simple_lens", {"max_coc_px": 250.0})
    t = measure_throughput(model)
    print(f"{t.model}: {t.mrays_per_second:.1f} M rays/s ({t.n_rays} rays, {t.rays_per_launch} per launch, "
          f"{t.resolution}^2 PSF, cell {t.cell}, {t.seconds:.3f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
