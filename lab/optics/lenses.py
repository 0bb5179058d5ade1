"""Built-in lens prescriptions by name, for ``[camera] lens = "NAME"`` (data only, no Dr.Jit).

Each lens is rows of :class:`lab.optics.thick_lens.Surface` (radius_mm, thickness_mm, glass,
aperture_radius_mm), object side first, radius 0 for the aperture stop and ``inf`` for a flat
opening; the last row's thickness is 0 (focusing places the sensor). Both lenses put a hood
opening in front of the iris, so oblique beams are clipped on one side by the hood and on the
other by the glass rim: cat-eye bokeh off axis.

==========  ================================================================  =======  ======
name        what it is                                                        EFL      f/
==========  ================================================================  =======  ======
singlet     bi-convex N-BK7 (R = +-50 mm, 8 mm thick), iris 10 mm in front    49.7 mm  2.8
achromat    cemented N-BK7 / F2 doublet (thin-lens achromat powers), iris      49.4 mm  3.1
            6 mm in front: about 1/8 of the singlet's axial colour
==========  ================================================================  =======  ======
"""
from __future__ import annotations

import math

__all__ = ["LENSES", "lens_names"]

LENSES: dict[str, tuple] = {
    "singlet": ((math.inf, 15.0, "air", 11.5),
                (0.0, 10.0, "air", 8.9),
                (50.0, 8.0, "N-BK7", 12.0),
                (-50.0, 0.0, "air", 12.0)),
    "achromat": ((math.inf, 12.0, "air", 10.0),
                 (0.0, 6.0, "air", 8.0),
                 (22.4, 6.0, "N-BK7", 9.0),
                 (-22.4, 2.0, "F2", 9.0),
                 (-406.0, 0.0, "air", 9.0)),
}


def lens_names() -> list[str]:
    """The built-in lens names, sorted."""
    return sorted(LENSES)
