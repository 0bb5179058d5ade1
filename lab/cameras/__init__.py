"""Camera models, one module each, registered by the ``[camera]`` table's ``model``:
``parse_camera(table, where)``, ``get_camera("thin")``.

Each model declares its scene keys, runtime twin, EXR header, plan rule and Mitsuba sensor
(:mod:`lab.cameras.base`). Importing this package registers every model (no Mitsuba or Dr.Jit).
"""
from lab.cameras.base import Camera, camera_names, get_camera, header_camera, parse_camera, register_camera
from lab.cameras import pinhole  # noqa: F401  (registers "pinhole")
from lab.cameras import thick  # noqa: F401  (registers "thick")
from lab.cameras import thin  # noqa: F401  (registers "thin")

__all__ = ["Camera", "camera_names", "get_camera", "header_camera", "parse_camera", "register_camera"]
