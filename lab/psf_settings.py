"""What a scene decides of a PSF model's settings: its ``[psf.<model>]`` table, filled in.

A scene's ``[psf.<model>]`` table only overrides; the rest of what the model needs from the scene
(the largest CoC from the depth range, and later the largest motion, the lens, the medium) is
derived here, one function per model in :data:`SCENE_SETTINGS`. A model without an entry takes
its table as it is.
"""
from __future__ import annotations

import math

from .errors import UserError

__all__ = ["SCENE_SETTINGS", "model_table"]


def _round_aperture(table: dict, scene, model: str) -> None:
    """A thin camera without an iris has a round aperture, and so does its reference: a table
    asking for another shape would build a database that cannot match it."""
    given = table.get("aperture", "circle")
    if given != "circle":
        raise UserError(f"{scene.source} [psf.{model}] aperture = {given!r}: the scene's [camera] has a "
                        "round aperture (its reference is traced through a disc), so this database "
                        "would not match it; remove the key, or give the [camera] that aperture")


def _simple_lens(table: dict, scene, image) -> dict:
    """``max_coc_px``: the largest |CoC| of the input, rounded up to a multiple of 8 px (so small
    scene edits reuse the database); ``psf_resolution``: the smallest that holds it. The
    aperture is the camera's (round): a table that says otherwise is an error naming both."""
    from .psf_tracing.models.simple_lens import min_psf_resolution
    from .reference.coc import coc_range

    _round_aperture(table, scene, "simple_lens")

    if "max_coc_px" not in table:
        needed = coc_range(image, scene.camera.thin_lens()).max_abs_px
        table["max_coc_px"] = float(max(8, 8 * math.ceil(needed / 8.0)))
    table.setdefault("psf_resolution", min_psf_resolution(table["max_coc_px"]))
    return table


# Model name -> fill(table, scene, labelled input) -> table.
SCENE_SETTINGS = {"simple_lens": _simple_lens}


def model_table(scene, model_name: str, image) -> dict:
    """The scene's ``[psf.<model_name>]`` table with what the scene decides filled in.

    Parameters
    ----------
    scene : lab.scene.Scene
    model_name : str
        A registered PSF model.
    image : lab.exr_io.LabelledImage
        The scene's labelled-pixel input (its depths fix the CoC range).
    """
    table = dict(scene.psf.get(model_name, {}))
    fill = SCENE_SETTINGS.get(model_name)
    return fill(table, scene, image) if fill else table
