"""Cameras of the ``splatlab.camera`` EXR header, one module per lens, registered by the header's
``"lens"`` value: :func:`from_header` builds the camera a header names.

=============  =================================================  ===============================
``"lens"``     class                                              circle of confusion
=============  =================================================  ===============================
``"thin"``     :class:`runtime_cl.camera.thin_lens.ThinLens`      a v W / sensor (1/F - 1/z) px
``"thick"``    :class:`runtime_cl.camera.thick_lens.ThickLens`    the same, paraxial: entrance
                                                                  pupil a, chief-ray scale v
``"pinhole"``  :class:`runtime_cl.camera.pinhole.Pinhole`         0
=============  =================================================  ===============================

Importing this package registers every lens (:mod:`runtime_cl.camera.common` says what a camera
provides). A new lens is one module here plus its import below.
"""
from runtime_cl.camera import pinhole, thick_lens, thin_lens  # noqa: F401  (they register their lens)
from runtime_cl.camera.common import from_header, lens_names, register_lens

__all__ = ["from_header", "lens_names", "register_lens"]
