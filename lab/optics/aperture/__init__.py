"""Aperture shapes as pluggable samplers, registered by name (Dr.Jit), one module per shape.

Shapes: ``circle`` (:mod:`.circle`); ``polygon`` (:mod:`.polygon`: blades, rotation, rounded
corners); ``image`` (:mod:`.image`: a user's transmittance PNG); ``star`` and ``heart``
(:mod:`.builtin`: built-in transmittance images). :mod:`.base` holds the :class:`Aperture`
contract and the registry; each shape module registers itself when imported, and the imports
below are the one list of them (Mitsuba's plugin style), so the registry is complete whichever
module a caller imports first. A new shape is a new module and one line here.
"""
from .base import Aperture, aperture_names, get_aperture, make_aperture, register_aperture
from .circle import CircleAperture
from .polygon import PolygonAperture
from .image import FileImageAperture, ImageAperture
from .builtin import HeartAperture, StarAperture

__all__ = ["Aperture", "CircleAperture", "PolygonAperture", "ImageAperture", "FileImageAperture",
           "StarAperture", "HeartAperture", "register_aperture", "get_aperture", "aperture_names",
           "make_aperture"]
