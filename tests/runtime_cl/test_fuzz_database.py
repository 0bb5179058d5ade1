"""Fuzzing the spreadlet database reader: truncations, byte flips and insertions of a small
database give the database back or an InputError, never another exception or a hang.

A flip in the zip's central directory can ask zlib to inflate a stored array or numpy to
allocate a shape its header claims; the reader refuses both. Seeded (derandomize) and bounded
(examples, deadline); ``-m slow`` runs 10 000 cases.
"""
import io
import os
import tempfile
import zipfile

import pytest
from fuzz_support import FAST, SLOW, read_mutated
from hypothesis import given, settings
from hypothesis import strategies as st

from runtime_cl.errors import InputError
from runtime_cl.psf.database import SpreadletDatabase
from runtime_cl.psf.synthetic import disc_database

FAST = settings(FAST, max_examples=200)      # cheap cases: a few more


def _good() -> bytes:
    buf = io.BytesIO()
    with tempfile.TemporaryDirectory() as d:
        disc_database(5.0, samples=4).save(os.path.join(d, "db.spdb"))
        with open(os.path.join(d, "db.spdb"), "rb") as fh:
            buf.write(fh.read())
    return buf.getvalue()


GOOD = _good()
# Where the zip's central directory starts: the bytes that describe every member.
CENTRAL = GOOD.rindex(b"PK\x01\x02", 0, GOOD.rindex(b"PK\x05\x06"))
CENTRAL = min(GOOD.find(b"PK\x01\x02"), CENTRAL)


@st.composite
def damaged(draw):
    data = bytearray(GOOD)
    for _ in range(draw(st.integers(1, 3))):
        op = draw(st.sampled_from(["truncate", "flip", "flip_directory", "flip_local_header", "insert", "zero"]))
        if not data:
            break
        if op == "truncate":
            del data[draw(st.integers(0, len(data) - 1)):]
        elif op == "flip":
            data[draw(st.integers(0, len(data) - 1))] ^= draw(st.integers(1, 255))
        elif op == "flip_directory" and len(data) > CENTRAL:
            data[draw(st.integers(CENTRAL, len(data) - 1))] ^= draw(st.integers(1, 255))
        elif op == "flip_local_header":      # a member's local header and its .npy header
            starts = [i for i in range(len(data) - 3) if data[i:i + 4] == b"PK\x03\x04"]
            at = draw(st.sampled_from(starts)) if starts else 0
            data[min(at + draw(st.integers(0, 160)), len(data) - 1)] ^= draw(st.integers(1, 255))
        elif op == "insert":
            i = draw(st.integers(0, len(data)))
            data[i:i] = draw(st.binary(min_size=1, max_size=16))
        else:
            i = draw(st.integers(0, len(data) - 1))
            data[i:i + draw(st.integers(1, 64))] = bytes(min(64, len(data) - i))
    return bytes(data)


def _load(path):
    db = SpreadletDatabase.load(path)
    assert db.compute_checksum() == db.checksum   # whatever loads is intact
    return db


def check(data: bytes):
    read_mutated(data, "db.spdb", _load, InputError)


def test_the_undamaged_file_loads():
    check(GOOD)
    assert zipfile.ZipFile(io.BytesIO(GOOD)).testzip() is None


def test_a_compressed_member_is_refused_not_inflated(tmp_path):
    """The issue's example: flipping the compression method of a central-directory entry."""
    data = bytearray(GOOD)
    entry = data.index(b"PK\x01\x02")
    data[entry + 10] = 8            # compression method: deflate
    (tmp_path / "db.spdb").write_bytes(bytes(data))
    with pytest.raises(InputError, match=r"unreadable, truncated or not a database|is compressed"):
        SpreadletDatabase.load(tmp_path / "db.spdb")


@FAST
@given(damaged())
def test_fuzz_database(data):
    check(data)


@pytest.mark.slow
@SLOW
@given(damaged())
def test_fuzz_database_10k(data):
    check(data)
