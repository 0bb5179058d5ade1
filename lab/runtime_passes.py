"""The plan's runtime passes on a labelled image: frames, apertures, databases and timings.

A plan lists its runtime passes by label (the method names of a report); each label is a
registered pass of :mod:`runtime_cl.passes` with options (:meth:`lab.plan.Plan.pass_run`, as
the camera's plan rule says). A pass that needs a database runs
once with every database the plan built whose model it renders (a ``volume_far`` database is no
model of its own: it is handed to the passes that render its ``volume`` database); a pass that draws the camera's
aperture gets the camera's iris, rectified here (the runtime ships only its built-in shapes).
Every pass is timed by the runtime's one contract (:mod:`runtime_cl.timing`).
"""
from __future__ import annotations

import numpy as np

from runtime_cl.frame import Frame
from runtime_cl.passes import get_pass, run_pass
from runtime_cl.psf.fingerprint import check_header

from .errors import UserError
from .motion import read_motion

TIMED_RUNS = 3
TIMED_MIN_MS = 300.0   # a few-millisecond pass (the tiny scenes) is timed until its calls add up to this


def frame_of(image, source: str = "input", db=None, layered_input: bool = False,
             stochastic: bool = False) -> Frame:
    """The runtime's :class:`~runtime_cl.frame.Frame` of a :class:`lab.exr_io.LabelledImage`:
    motion when ``db`` is a motion database, the ``layerN.*`` layers when ``layered_input``, the
    checked ``lens.U, lens.V, time`` when ``stochastic`` (a pass reading them)."""
    from runtime_cl.coords.maps import needs_motion

    motion = read_motion(image, source, db.model) if db is not None and needs_motion(db.model) else None
    layers = ()
    if layered_input:
        found = image.layers(source)
        if not found:
            raise UserError(f"{source}: the input has no layerN.* channels; render it with layers (a scene "
                            "whose [[shapes]] have a layer key) or splat the flat image")
        layers = tuple(Frame(x.rgb, x.depth, alpha=x.alpha) for x in found)
    samples = depths = None
    if stochastic:
        from runtime_cl.stochastic import channel_depths, lens_time_samples

        samples = lens_time_samples(image.extra, source, image.depth.shape)
        depths = channel_depths(image.extra, source, image.depth)
    return Frame(image.rgb, image.depth, alpha=image.alpha, motion=motion, layers=layers,
                 guard_px=image.guard_px, samples=samples, channel_depth=depths)


def camera_aperture(image, source: str = "input camera header", directions_m: int = 2, edges=None):
    """The rectified polygon of the image camera's iris, or None for a round aperture; a stylized
    shape (``{"shape": ...}``) is no polygon of the camera's: an error that says what draws it."""
    if "aperture" not in image.camera:
        return None
    shape = image.camera["aperture"].get("shape") if isinstance(image.camera["aperture"], dict) else None
    if shape is not None:
        raise UserError(f"{source} aperture = {image.camera['aperture']!r}: the camera's stylized {shape} is "
                        "drawn by its stylized database (--method spreadlets --db stylized.spdb); the polygon "
                        "method draws an iris or a built-in shape (--aperture NAME)")
    from .config import from_table
    from .optics.iris import Iris
    from .polygon_aperture import iris_aperture

    return iris_aperture(from_table(Iris, image.camera["aperture"], f"{source} aperture"), directions_m, edges)


def aperture_info(aperture) -> dict:
    """What a report says of a rectified aperture."""
    return {"edges": aperture.edges, "rectify_s": round(aperture.rectify_s, 3),
            "table_s": round(aperture.splatter.table.build_seconds, 3)}


def with_pass_options(plan, table: dict):
    """``plan`` with the options of ``table`` (``--set KEY=VALUE``) given to every runtime pass
    that takes them; an option no pass takes is an error naming the passes' options."""
    from dataclasses import replace

    from runtime_cl.passes import pass_options

    if not table:
        return plan
    takes = {label: pass_options(get_pass(plan.pass_run(label)[0])) for label in plan.runtime_passes}
    for key, value in table.items():
        if not any(key in t for t in takes.values()):
            names = sorted({k for t in takes.values() for k in t})
            raise UserError(f"--set {key}={value!r}: no pass of the plan ({', '.join(plan.runtime_passes)}) takes "
                            f"{key!r}; their options are {', '.join(names) or 'none'}")
    return replace(plan, pass_runs={
        label: (plan.pass_run(label)[0], dict(plan.pass_run(label)[1], **{k: v for k, v in table.items()
                                                                           if k in takes[label]}))
        for label in plan.runtime_passes})


def run_runtime(plan, image, databases: dict, runs: int = TIMED_RUNS, min_ms: float = TIMED_MIN_MS,
                progress: bool = True) -> dict:
    """Every runtime pass of the plan on ``image``: report label -> (image, timing dict).

    ``databases``: model name -> :class:`lab.precompute.PrecomputeResult` (what the plan built).
    """
    from runtime_cl.psf.database import SpreadletDatabase
    from tqdm import tqdm

    from runtime_cl.psf.far_field import MODEL as FAR_FIELD

    camera = runtime_camera(image)
    dbs = {name: SpreadletDatabase.load(r.path, expect_model=name) for name, r in databases.items()}
    far = dbs.pop(FAR_FIELD, None)   # no pass renders it alone: it completes the volume database
    if far is not None:
        check_header(far, image.camera)
    aperture = None
    out = {}
    for label in tqdm(plan.runtime_passes, desc="runtime", unit="method", disable=not progress):
        name, options = plan.pass_run(label)
        cls = get_pass(name)
        if cls.draws_aperture:
            aperture = aperture or camera_aperture(image)
            if aperture is not None:
                options = dict(options, aperture=aperture.splatter)
        candidates = [None] if cls.database_models == () else \
            [db for db in dbs.values() if cls.database_models is None or db.model in cls.database_models]
        if not candidates:
            raise UserError(f"runtime pass {label!r} needs a database; the plan built {sorted(dbs)}")
        for db in candidates:
            if db is not None:
                check_header(db, image.camera)
            key = label if len(candidates) == 1 else f"{label}:{db.model}"
            frame = frame_of(image, db=db, layered_input=options.get("layered_input", False),
                             stochastic="lens.U" in cls.channels)
            rendered, timing = run_pass(name, frame, camera, db, runs=runs, min_ms=min_ms, **options,
                                        **far_field_option(cls, db, far))
            entry = dict(timing.to_json(), **{"pass": name})
            if cls.draws_aperture and aperture is not None:
                entry["aperture"] = aperture_info(aperture)
            out[key] = (rendered, entry)
    return out


def far_field_option(cls, db, far) -> dict:
    """``{"far_field": far}`` where the pass class ``cls`` adds a far field and the ``volume_far``
    database ``far`` (or None) completes ``db``, a ``volume`` database; else {}."""
    return {"far_field": far} if far is not None and cls.far_field and db is not None and db.model == "volume" else {}


def runtime_camera(image, source: str = "input camera header"):
    """The runtime camera of the image's ``splatlab.camera`` header (:func:`runtime_cl.camera.from_header`)."""
    from runtime_cl.camera import from_header

    return from_header(image.camera, source)


def read_input(path, camera_file=None):
    """A labelled-pixel EXR for ``splatlab render``; ``camera_file`` (TOML) overrides its header."""
    from .exr_io import read_labelled

    camera = None
    if camera_file is not None:
        from .focal_constraints import unresolved
        from .focus import surface_from_depth
        from .scene import load_camera

        cam = load_camera(camera_file)
        if unresolved(getattr(cam, "focal_surface", None)):   # blur constraints: the depths the input sees
            image = read_labelled(path)
            depth = np.where(np.asarray(image.alpha) > 0, np.asarray(image.depth, np.float64), np.inf)
            cam = surface_from_depth(cam, depth, f"{camera_file} [camera]")
        camera = cam.camera_json()
    return read_labelled(path, camera=camera)
