"""The rectified built-in shapes the runtime ships: ``python -m lab.polygon.ship``.

Every built-in shape (:data:`runtime_cl.polygon.shapes.SHAPES`) is rectified as
:func:`lab.polygon_aperture.polygon_aperture` does by default, with MHU21's D
(:data:`~runtime_cl.polygon.shapes.SHIPPED_DIRECTIONS_M` = 2) and the shape's default edge budget,
and its unit polygon is written to ``runtime_cl/polygon/shapes.json``, atomically, for
:func:`runtime_cl.polygon.shapes.unit_polygon`: polygonal bokeh then needs no rectification, so no
Numba or Shapely, at run time. JSON keeps every float64 exactly (shortest round-trip repr).
``tests/lab/polygon/test_ship.py`` rectifies again and compares, so the file cannot go stale: after
changing the shapes or the rectification, run this module and commit the file.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from runtime_cl.atomic_file import atomic_path
from runtime_cl.polygon.shapes import SHAPES, SHIPPED, SHIPPED_DIRECTIONS_M, SHIPPED_FORMAT, shape

__all__ = ["rectified_shapes", "shipped_text", "write_shipped", "main"]


def rectified_shapes() -> dict:
    """``{name: {"edges", "vertices", "directions"}}`` for every built-in shape, freshly rectified."""
    from lab.polygon.rectify import direction_set, rectify
    from lab.polygon_aperture import default_edges

    out = {}
    for name in SHAPES:
        edges = default_edges(name)
        vertices, directions = rectify(shape(name), direction_set(SHIPPED_DIRECTIONS_M), edges).unit()
        out[name] = {"edges": edges, "vertices": vertices.tolist(), "directions": directions.tolist()}
    return out


def shipped_text(shapes: dict | None = None) -> str:
    """The content of ``shapes.json`` for ``shapes`` (default :func:`rectified_shapes`): one line per
    shape and key, so a change shows as a readable diff."""
    shapes = rectified_shapes() if shapes is None else shapes
    rows = [f'  "{name}": {{\n' + ",\n".join(f'   "{k}": {json.dumps(v)}' for k, v in entry.items())
            + "\n  }" for name, entry in shapes.items()]
    return (f'{{\n "format": {SHIPPED_FORMAT},\n "directions_m": {SHIPPED_DIRECTIONS_M},\n'
            ' "shapes": {\n' + ",\n".join(rows) + "\n }\n}\n")


def write_shipped(path=SHIPPED) -> Path:
    """Rectify every built-in shape and write ``path`` (default: the runtime's ``shapes.json``)."""
    path = Path(path)
    text = shipped_text()
    with atomic_path(path) as tmp:
        tmp.write_text(text)
    return path


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m lab.polygon.ship", description=__doc__.split("\n")[0])
    parser.add_argument("--out", type=Path, default=SHIPPED, help=f"where to write (default {SHIPPED})")
    args = parser.parse_args(argv)
    print(f"wrote {write_shipped(args.out)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
