"""Optics in Dr.Jit, the lab's single source of truth, one concept per module:

``thin_lens`` (paraxial thin lens, CoC), ``aperture`` (a package: iris shapes, one module each,
registered by name), ``motion`` (linear motion over the shutter), ``glass`` (Sellmeier
catalog), ``thick_lens`` (a lens as a list of spherical surfaces, Snell's law), ``lens_camera``
(a thick lens focused on a distance, with its sensor) and ``media`` (Henyey-Greenstein phase,
Woodcock tracking). Importing this package loads nothing heavy.
"""
