"""``[scene] extends``: a scene file on top of another (tables merge key by key, other values replace)."""
import pytest

from lab.errors import UserError
from lab.paths import SCENES
from lab.scene import load_scene

BASE = """
[scene]
name = "base"
resolution = [64, 48]
[camera]
model = "pinhole"
position = [0.0, 0.0, 0.0]
look_at = [0.0, 0.0, 1.0]
fov_deg = 40.0
[render]
reference_spp = 16
input_spp = 8
seed = 3
[materials.grey]
reflectance = [0.5, 0.5, 0.5]
[[shapes]]
type = "sphere"
center = [0.0, 0.0, 3.0]
radius = 0.5
material = "grey"
"""


def test_the_validation_demo_is_the_demo_with_more_samples():
    demo, val = load_scene(SCENES / "demo.toml"), load_scene(SCENES / "demo_validation.toml")
    assert val.info.name == "demo_validation" and val.info.resolution == demo.info.resolution
    assert val.shapes == demo.shapes and val.emitters == demo.emitters and val.camera == demo.camera
    assert val.render.reference_spp == 4096 and val.render.seed == demo.render.seed
    assert val.render.max_depth == demo.render.max_depth and val.render.peel_layers == 4


def test_tables_merge_and_arrays_replace(tmp_path):
    (tmp_path / "base.toml").write_text(BASE)
    (tmp_path / "more.toml").write_text('[scene]\nextends = "base.toml"\nname = "more"\n[render]\nreference_spp = 64\n'
                                        '[[shapes]]\ntype = "sphere"\ncenter = [0.0, 0.0, 5.0]\nradius = 1.0\nmaterial = "grey"\n')
    (tmp_path / "most.toml").write_text('[scene]\nextends = "more.toml"\nname = "most"\n[render]\ninput_spp = 32\n')
    s = load_scene(tmp_path / "most.toml")
    assert s.info.name == "most" and s.info.resolution == (64, 48)
    assert (s.render.reference_spp, s.render.input_spp, s.render.seed) == (64, 32, 3)
    assert len(s.shapes) == 1 and s.shapes[0].radius == 1.0               # [[shapes]] replaced, not appended


@pytest.mark.parametrize("extends, match", [
    ('"missing.toml"', r"missing\.toml.*fix \[scene\] extends in"),
    ('"../base.toml"', r"extends = '\.\./base\.toml': give the file name of a scene in the same folder"),
    ("3", r"extends = 3: give the file name"),
    ('"loop.toml"', r"more than 4 files long \(a cycle\?\)"),
])
def test_a_bad_extends_names_the_file_and_the_fix(tmp_path, extends, match):
    (tmp_path / "loop.toml").write_text(f'[scene]\nextends = {extends}\nname = "loop"\n')
    with pytest.raises(UserError, match=match):
        load_scene(tmp_path / "loop.toml")
