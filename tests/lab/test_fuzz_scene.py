"""Fuzzing the scene reader: mutations of the shipped scenes give a valid plan or a UserError.

Structured mutations (a value replaced, a key dropped or added, a list entry doubled) go through
:func:`lab.scene.parse_scene`, the plan and the early ``[psf.*]`` checks; text mutations (bytes
flipped, inserted, cut) through :func:`lab.pipeline.load_scene_and_plan`, what every command runs. Seeded (derandomize) and bounded (examples,
deadline); ``-m slow`` runs 10 000 cases of each.
"""
import copy
import math
import tomllib

import pytest
from fuzz_support import FAST, SLOW, read_mutated
from hypothesis import given
from hypothesis import strategies as st

from lab.errors import UserError
from lab.paths import SCENES
from lab.pipeline import load_scene_and_plan
from lab.plan import make_plan
from lab.psf_settings import check_tables
from lab.scene import _extended, parse_scene

SHIPPED = {p.name: p.read_bytes() for p in sorted(SCENES.glob("*.toml"))}
# [scene] extends resolved (a value fuzzer mutates the whole scene)
PARSED = {name: _extended(tomllib.loads(data.decode()), SCENES / name) for name, data in SHIPPED.items()}

VALUES = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True), st.integers(-2 ** 70, 2 ** 70), st.booleans(),
    st.text(max_size=6), st.sampled_from(["../x", "", "a\0b", "a/b", "circle", "thin", "thick", "pinhole",
                                          "sphere", "simple_lens", "N-BK7", "hexagon"]),
    st.lists(st.floats(allow_nan=True, allow_infinity=True), max_size=5), st.lists(st.integers(-9, 9), max_size=5),
    st.dictionaries(st.sampled_from(["x", "shape", "blades", "sigma_t"]), st.integers(-3, 3), max_size=2))


def _paths(data, prefix=()):
    """Every (container, key) pair of a parsed TOML document."""
    items = data.items() if isinstance(data, dict) else enumerate(data) if isinstance(data, list) else ()
    for key, value in items:
        yield prefix + (key,)
        yield from _paths(value, prefix + (key,))


def _parent(data, path):
    for key in path[:-1]:
        data = data[key]
    return data


@st.composite
def mutated_scene(draw):
    name = draw(st.sampled_from(sorted(PARSED)))
    data = copy.deepcopy(PARSED[name])
    for _ in range(draw(st.integers(1, 3))):
        paths = list(_paths(data))
        path = draw(st.sampled_from(paths))
        parent, key = _parent(data, path), path[-1]
        op = draw(st.sampled_from(["replace", "replace", "drop", "add", "double"]))
        if op == "replace":
            parent[key] = draw(VALUES)
        elif op == "drop":
            del parent[key]
        elif op == "add" and isinstance(parent, dict):
            parent[draw(st.sampled_from(["extra", "layer", "velocity", "aperture", "medium", "samples", "max_coc_px",
                                         "max_motion_px", "psf_resolution", "min_distance_m"]))] = draw(VALUES)
        elif op == "double" and isinstance(parent, list):
            parent.append(copy.deepcopy(parent[key]))
    return name, data


@st.composite
def mutated_text(draw):
    name = draw(st.sampled_from(sorted(SHIPPED)))
    data = bytearray(SHIPPED[name])
    for _ in range(draw(st.integers(1, 4))):
        op = draw(st.sampled_from(["flip", "insert", "cut", "truncate"]))
        i = draw(st.integers(0, max(len(data) - 1, 0)))
        if op == "flip" and data:
            data[i] ^= draw(st.integers(1, 255))
        elif op == "insert":
            data[i:i] = draw(st.sampled_from([b"nan", b"inf", b"-", b"1e999", b"[", b"]", b"=", b'"', b"\xff",
                                              b"\n[scene]\n", b"\n[[shapes]]\n", b"\x00", b"../"]))
        elif op == "cut":
            del data[i:i + draw(st.integers(1, 40))]
        else:
            del data[i:]
    return name, bytes(data)


def check_plan(data, source):
    """A valid scene plans; anything else is a UserError; no other exception escapes."""
    try:
        scene = parse_scene(data, source)
        check_tables(scene, make_plan(scene).psf_models)
    except UserError as exc:
        assert str(exc) and "\n" not in str(exc), repr(exc)


def check_file(data: bytes):
    read_mutated(data, "s.toml", load_scene_and_plan, UserError)


def test_shipped_scenes_plan():
    from lab.focus import resolve_focus

    for name, data in PARSED.items():
        make_plan(resolve_focus(parse_scene(copy.deepcopy(data), name)))   # focus_point(s): from their depths


@FAST
@given(mutated_scene())
def test_fuzz_scene_values(case):
    check_plan(*reversed(case))


@FAST
@given(mutated_text())
def test_fuzz_scene_text(case):
    check_file(case[1])


@pytest.mark.slow
@SLOW
@given(mutated_scene())
def test_fuzz_scene_values_10k(case):
    check_plan(*reversed(case))


@pytest.mark.slow
@SLOW
@given(mutated_text())
def test_fuzz_scene_text_10k(case):
    check_file(case[1])


def test_no_math_on_nan_reaches_the_plan():
    """The finite check comes before every table's own checks (a NaN radius is not 'must be > 0')."""
    data = copy.deepcopy(PARSED["tiny.toml"])
    data["shapes"][2]["radius"] = math.nan
    with pytest.raises(UserError, match=r"shapes #3.radius = nan: must be a finite number"):
        parse_scene(data, "tiny.toml")


@pytest.mark.parametrize("value", [[1, 2], "", True, -4])
def test_found_by_fuzzing_a_volume_psf_resolution_of_the_wrong_type(value):
    """10 000-case run: ``[psf.volume] psf_resolution = []`` or ``""`` reached ``int()`` in the plan."""
    data = copy.deepcopy(PARSED["tiny_fog.toml"])
    data["psf"]["volume"]["psf_resolution"] = value
    with pytest.raises(UserError, match=r"tiny_fog.toml \[psf.volume\]: psf_resolution = .*must be an integer"):
        make_plan(parse_scene(data, "tiny_fog.toml"))


def test_a_thick_lens_focus_not_yet_resolved_is_a_user_error():
    """focus_points on a thick lens before lab.focus.resolve_focus (what the value fuzzer plans):
    one line, not a TypeError from the lens's focusing (a case the fuzzer found)."""
    with pytest.raises(UserError, match="focus is not resolved yet"):
        make_plan(parse_scene(copy.deepcopy(PARSED["tiny_thick_tiltshift.toml"]), "tiny_thick_tiltshift.toml"))
