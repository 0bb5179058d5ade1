"""Header JSON with limits: size, depth, integer digits, NaN/Infinity; bool is not a number."""
import json
import re

import pytest

from runtime_cl.errors import InputError
from runtime_cl.json_values import MAX_DEPTH, is_number, loads


def test_plain_json_round_trips():
    data = {"lens": "thin", "focal_length_mm": 50, "shutter": [0.0, 1.0], "surfaces": [[1.5, "[{", 2]]}
    assert loads(json.dumps(data), "src", "fix") == data
    assert loads(json.dumps(data).encode(), "src", "fix") == data


@pytest.mark.parametrize("text, needle", [
    ("[" * (MAX_DEPTH + 1) + "]" * (MAX_DEPTH + 1), f"nested {MAX_DEPTH + 1} deep"),
    ("[" * 200000 + "]" * 200000, "nested 200000 deep"),        # would recurse in the decoder
    ('{"f": ' + "9" * 400 + "}", "integer of 400 digits"),      # would overflow float()
    ('{"f": NaN}', "NaN is not a JSON number"),
    ('{"f": -Infinity}', "-Infinity is not a JSON number"),
    ('{"f": 1e400}', "1e400 is beyond float range"),
    ("{lens: thin", "not JSON"),
    (b"\xff{}", "not UTF-8"),
    ("x" * (2 << 20), "more than the"),
])
def test_limits(text, needle):
    with pytest.raises(InputError) as exc:
        loads(text, "in.exr header 'splatlab.camera'", "pass --camera")
    msg = str(exc.value)
    assert needle in msg and msg.startswith("in.exr header 'splatlab.camera': ") and msg.endswith("pass --camera")
    assert "\n" not in msg


def test_nan_allowed_for_reports():
    assert loads('{"ssim": NaN}', "r", "f", allow_nan=True)["ssim"] != 0


def test_is_number():
    assert is_number(1) and is_number(2.5) and not is_number(True) and not is_number(False)
    assert not is_number(float("nan")) and not is_number(float("inf")) and is_number(float("inf"), finite=False)
    assert not is_number("1") and not is_number(None) and is_number(10 ** 400)


def test_infinity_only_under_the_named_keys():
    """A thick lens's flat faces are Infinity in its header; anywhere else Infinity (and NaN
    everywhere) is refused, naming where it was."""
    data = loads('{"surfaces": [[Infinity, 3.0], [-Infinity, 0.0]], "f": 1.0}', "h", "fix",
                 infinite_keys=("surfaces",))
    assert data["surfaces"][0][0] == float("inf") and data["surfaces"][1][0] == float("-inf")
    for text, said in (('{"surfaces": [], "f": Infinity}', "Infinity at 'f'"),
                       ('{"surfaces": [[NaN]]}', "NaN is not a JSON number"),
                       ('{"a": [1, {"b": -Infinity}]}', "Infinity at 'a'[1]['b']")):
        with pytest.raises(InputError, match=re.escape(said)):
            loads(text, "h", "fix", infinite_keys=("surfaces",))
    with pytest.raises(InputError, match="Infinity is not a JSON number"):
        loads('{"surfaces": [[Infinity]]}', "h", "fix")
