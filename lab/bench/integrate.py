"""``splatlab bench integrate``: the Poisson integrators (``exact``, ``fft32``, ``pyramid``, every
registered one) on the same Laplacian canvases, errors against the exact solve and times, each
ratio from one run.

Canvases (RGB float32, zero on their border ring, as the spreadlet runtime's are):

- ``defocus_1024``: the Laplacian canvas the ``spreadlets`` method splats for a 1024^2 image laid
  out like the demo's shallow depth of field (:func:`runtime_cl.psf.synthetic.defocus_scene`,
  largest CoC 84 px as the demo's; exact Laplacians of 1 px soft-rimmed discs,
  :func:`runtime_cl.psf.synthetic.disc_database`, discs under 4 px on the dense fast track), on
  its padded canvas (1024 + 2 pad, FFT-friendly);
- ``<scene>`` (``--scene``, default the demo): the Laplacian canvas the ``spreadlets`` pass
  integrates for the scene's own labelled input, its ``simple_lens`` database fitted in LSR18's
  Laplacian basis (the scene's database may store row differences, which need no integration):
  :func:`scene_canvas`;
- ``random_1024`` and ``random_4096``: sparse random PSF sums on the padded canvas of a 1024^2 and
  a 4096^2 image (:func:`runtime_cl.psf.synthetic.psf_sum_image`: soft-rimmed discs of
  log-uniform radii 1 ... n/12, rims 1-8 px, exponential intensities per channel) and their
  5-point Laplacian.

Error of an integrator on a canvas: per pixel and channel ``|out - exact| / max|exact|`` (the
channel's largest absolute value), its mean and max over all pixels and channels. ``exact`` is
:func:`runtime_cl.integrate.poisson.poisson_integrate` in float64; its own error against the
image the random canvases were made from is reported as the floor (float32 rounding).

Times: wall clock of one call from a host array to a host array (the integrators' contract;
the pyramid's includes its upload and download), after one warm-up call, the integrators
interleaved in a rotating order in every repeat on the shared machine; ratios
(``exact_over_<name>``) are taken within a repeat and reported as median, min and max, single
times as median, min and max over repeats. The pyramid's OpenCL event times are kept beside.
"""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np

__all__ = ["bench_integrate", "random_canvas", "defocus_canvas", "scene_canvas", "relative_error", "measure_case"]


def _spread(values) -> dict:
    v = np.asarray(values, np.float64)
    return {"median": float(np.median(v)), "min": float(v.min()), "max": float(v.max())}


def relative_error(out: np.ndarray, exact: np.ndarray) -> dict:
    """Mean and max over pixels and channels of ``|out - exact| / max|exact|`` (per channel)."""
    scale = np.abs(exact).max(axis=(0, 1))
    scale = np.where(scale > 0, scale, 1.0)
    e = np.abs(out.astype(np.float64) - exact) / scale
    return {"mean": float(e.mean()), "max": float(e.max())}


def random_canvas(n: int, seed: int, channels: int = 3):
    """A sparse random PSF sum on an (n, n, channels) canvas, zero near its border
    (:func:`runtime_cl.psf.synthetic.psf_sum_image`), and its 5-point Laplacian (float32).
    Returns ``(laplacian, image)``."""
    from runtime_cl.integrate.poisson import laplacian5
    from runtime_cl.psf.synthetic import psf_sum_image

    image = psf_sum_image(n, seed, channels=channels)
    return laplacian5(image).astype(np.float32), image


def defocus_canvas(n: int = 1024, r_max: float = 84.0, seed: int = 0, device=None):
    """The spreadlets method's Laplacian canvas of :func:`runtime_cl.psf.synthetic.defocus_scene`
    at n^2 with disc PSFs up to ``r_max`` px. Returns ``(laplacian (Hc, Wc, 3), pad)``."""
    import pyopencl as cl

    from runtime_cl.device.opencl import get_device
    from runtime_cl.psf.synthetic import defocus_scene, disc_database
    from runtime_cl.psf.upload import DeviceDatabase
    from runtime_cl.spreadlets.splat import TileSplatter

    device = device or get_device()
    # discs under 4 px take the dense fast track, as a real database's small PSFs do (a disc's
    # Laplacian has ~12 r points against its pi r^2: sparse pays from r ~ 4)
    db = disc_database(r_max, samples=32, edge=1.0, fast_track_below=4.0)
    colour, coords = defocus_scene(n, n, r_max, 3, seed)
    splatter = TileSplatter(DeviceDatabase(db, device), 3, dense_all=False)
    flags = cl.mem_flags.READ_ONLY | cl.mem_flags.COPY_HOST_PTR
    bufs = [cl.Buffer(device.context, flags, hostbuf=a) for a in (colour, coords)]
    out = splatter.run(*bufs, n, n)
    return out.canvas[0].copy(), out.pad   # the splatter reuses its host canvas


def scene_canvas(scene_path, device=None):
    """The Laplacian canvas the ``spreadlets`` pass integrates for ``scene_path``'s labelled input
    (a round thin lens: its ``simple_lens`` database, built or reused with ``basis = "laplacian"``),
    recorded as the pass hands it to its integrator. Returns ``(laplacian (Hc, Wc, 3), scene name)``."""
    from dataclasses import replace

    from lab.errors import UserError
    from lab.pipeline import build_databases, input_only, load_scene_and_plan
    from lab.runtime_passes import frame_of, runtime_camera
    from runtime_cl.passes import get_pass
    from runtime_cl.psf.database import SpreadletDatabase

    scene, plan = load_scene_and_plan(scene_path)
    if tuple(plan.psf_models) != ("simple_lens",):
        raise UserError(f"--scene {scene_path}: its plan traces {list(plan.psf_models)}; the integrate bench "
                        "records a round thin lens's simple_lens canvas (e.g. scenes/demo.toml)")
    tables = dict(scene.psf, simple_lens=dict(scene.psf.get("simple_lens", {}), basis="laplacian"))
    scene = replace(scene, psf=tables)
    image = input_only(scene)
    result = build_databases(scene, plan, image)["simple_lens"]
    db = SpreadletDatabase.load(result.path, expect_model="simple_lens")
    spreadlets = get_pass("spreadlets")(runtime_camera(image), db, device=device, integrator="exact")
    recorded, integrate = [], spreadlets.renderer.integrator

    def record(plane):
        recorded.append(np.array(plane, np.float32, copy=True))
        return integrate(plane)
    spreadlets.renderer.integrator = record
    spreadlets(spreadlets.prepare(frame_of(image, db=db)))
    (lap,) = recorded
    return lap, scene.name


def measure_case(lap: np.ndarray, integrators: dict, repeats: int, truth: np.ndarray | None = None) -> dict:
    """Errors and interleaved times of every integrator on one canvas (see the module)."""
    exact = integrators["exact"](lap)[0].astype(np.float64)
    row = {"canvas": list(lap.shape), "integrators": {}}
    if truth is not None:
        row["floor"] = relative_error(exact, truth.astype(np.float64))
    names = list(integrators)
    outs = {}
    for name in names:                                   # warm-up (builds, buffers), kept for errors
        outs[name] = integrators[name](lap)[0]
    wall = {n: [] for n in names}
    device = {n: [] for n in names}
    for i in range(repeats):
        for name in names[i % len(names):] + names[:i % len(names)]:   # no integrator always first
            t = time.perf_counter()
            _, times = integrators[name](lap)
            wall[name].append((time.perf_counter() - t) * 1e3)
            device[name].append(times["device_ms"])
    for name in names:
        row["integrators"][name] = {"error": relative_error(outs[name], exact), "ms": _spread(wall[name]),
                                    "device_ms": _spread(device[name])}
        if name != "exact":
            row["integrators"][name]["exact_over_this"] = _spread(np.array(wall["exact"]) / np.array(wall[name]))
    return row


def bench_integrate(repeats: int = 5, sizes=(1024, 4096), scene=None) -> Path:
    """Run the benchmark (module docstring) and write ``reports/bench/integrate-*.json``;
    ``scene`` (a path, optional): also its own spreadlet canvas (:func:`scene_canvas`)."""
    from runtime_cl.device.opencl import get_device
    from runtime_cl.integrate import get_integrator, integrator_names

    from .output import write_bench

    device = get_device()
    integrators = {name: get_integrator(name)(device) for name in integrator_names()}
    cases = {}
    if 1024 in sizes:
        lap, pad = defocus_canvas(1024, device=device)
        cases["defocus_1024"] = dict(measure_case(lap, integrators, repeats), pad=pad)
    if scene is not None:
        lap, name = scene_canvas(scene, device)
        cases[f"scene_{name}"] = dict(measure_case(lap, integrators, repeats), scene=str(scene))
    for n in sizes:
        lap, image = random_canvas(fft_size(n), seed=n)
        cases[f"random_{n}"] = measure_case(lap, integrators, repeats, truth=image)
        del lap, image
    return write_bench("integrate", {"repeats": repeats, "device": device.describe(), "cases": cases})


def fft_size(n: int) -> int:
    """The canvas side for an n^2 image with the runtime's padding at the demo's PSF size."""
    from runtime_cl.integrate.poisson import fft_friendly

    return fft_friendly(n + 2 * 88)
