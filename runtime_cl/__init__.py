"""splatlab's OpenCL runtime library: numpy + pyopencl only (never lab, mitsuba or drjit).

Public API (function first)::

    import runtime_cl
    db = runtime_cl.load_database("simple_lens.spdb")
    image, timing = runtime_cl.render(rgb, depth, camera, db, method="spreadlets")

:func:`render` runs any registered runtime pass (:func:`methods`; :mod:`runtime_cl.passes`) and
returns the image with one :class:`~runtime_cl.timing.Timing`; the ``spreadlets`` pass takes an
``integrator`` (:func:`integrators`; :mod:`runtime_cl.integrate`). Cameras live in
:mod:`runtime_cl.camera`, the database format in :mod:`runtime_cl.psf.database`.
"""
from runtime_cl.api import integrators, load_database, methods, render
from runtime_cl.camera.thin_lens import ThinLens
from runtime_cl.errors import InputError
from runtime_cl.frame import Frame
from runtime_cl.timing import Timing

__all__ = ["Frame", "InputError", "ThinLens", "Timing", "integrators", "load_database", "methods", "render"]
