"""The spreadlet database file: round trip, atomic save, and clear errors for bad files."""
import json
import os

import numpy as np
import pytest
from cl_reference import STATS, random_database

from runtime_cl.psf.database import DatabaseBuilder, SpreadletDatabase
from runtime_cl.errors import InputError
from runtime_cl.psf.grid import NestedGrid


@pytest.fixture
def db():
    return random_database(np.random.default_rng(3), samples=10, channels=3)


def assert_same(a, b):
    assert a.model == b.model and a.params == b.params and a.grid == b.grid
    assert a.channels == b.channels and a.psf_resolution == b.psf_resolution
    for name in ("C", "P", "V", "fast_track", "dense_radius", "dense_offsets", "dense_values"):
        x, y = getattr(a, name), getattr(b, name)
        assert x.dtype == y.dtype and np.array_equal(x, y), name
    assert sorted(a.stats) == sorted(b.stats)
    for k in a.stats:
        assert np.array_equal(a.stats[k], b.stats[k])


def test_round_trip_and_info(db, tmp_path):
    path = tmp_path / "x.spdb"
    checksum = db.save(path)
    assert path.exists() and not path.with_suffix(".spdb.npz").exists()
    assert os.listdir(tmp_path) == ["x.spdb"]  # no temporary file left
    back = SpreadletDatabase.load(path, expect_model="simple_lens")
    assert_same(db, back)
    assert back.checksum == checksum == back.compute_checksum()
    info = back.info()
    assert info["checksum_ok"] is True
    assert info["samples"] == db.grid.size and info["spreadlets"] == int(db.C[-1])
    assert info["fast_track"] == int(db.fast_track.sum())
    assert info["file_bytes"] == path.stat().st_size
    assert info["mean_sparsity"] == pytest.approx(STATS["sparsity"])
    json.dumps(info)  # `splatlab db info` prints it as JSON


def test_accessors(db):
    i = 3
    p, v = db.spreadlets(i)
    assert len(p) == db.C[i + 1] - db.C[i] and v.shape == (len(p), 3)
    r = db.dense_radius[i]
    assert db.dense_psf(i).shape == (2 * r + 1, 2 * r + 1, 3)
    assert db.pad == max(int(np.abs(db.P.astype(int)).max()), int(db.dense_radius.max())) + 1


def test_failed_save_leaves_nothing_and_keeps_the_old_file(db, tmp_path, monkeypatch):
    path = tmp_path / "x.spdb"
    db.save(path)
    before = path.read_bytes()

    def boom(*args, **kwargs):
        raise OSError("disk full")

    monkeypatch.setattr(np, "savez", boom)
    with pytest.raises(OSError, match="disk full"):
        db.save(path)
    assert os.listdir(tmp_path) == ["x.spdb"]
    assert path.read_bytes() == before


def test_truncated_file(db, tmp_path):
    path = tmp_path / "x.spdb"
    db.save(path)
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])
    with pytest.raises(InputError, match=r"x\.spdb.*truncated.*splatlab precompute"):
        SpreadletDatabase.load(path)


def test_corrupt_content_fails_the_checksum(db, tmp_path):
    path = tmp_path / "x.spdb"
    db.save(path)
    with np.load(path) as z:
        arrays = {k: z[k] for k in z.files}
    arrays["V"] = arrays["V"].copy()
    arrays["V"][0, 0] += 1.0
    with open(path, "wb") as f:
        np.savez(f, **arrays)
    with pytest.raises(InputError, match=r"x\.spdb: corrupt \(checksum mismatch.*splatlab precompute"):
        SpreadletDatabase.load(path)


@pytest.mark.parametrize("content", [b"hello, not a database\n", None])
def test_foreign_file(tmp_path, content):
    path = tmp_path / "foreign.npz"
    if content is None:
        np.savez(path, a=np.arange(3))  # a valid npz, but not ours
    else:
        path.write_bytes(content)
    with pytest.raises(InputError, match=r"foreign\.npz"):
        SpreadletDatabase.load(path)


def test_missing_file(tmp_path):
    with pytest.raises(InputError, match=r"nope\.spdb: no such file.*precompute"):
        SpreadletDatabase.load(tmp_path / "nope.spdb")


def test_other_model_or_version(db, tmp_path):
    path = tmp_path / "x.spdb"
    db.save(path)
    with pytest.raises(InputError, match=r"built for model 'simple_lens'.*'combined'.*precompute"):
        SpreadletDatabase.load(path, expect_model="combined")
    with np.load(path) as z:
        arrays = {k: z[k] for k in z.files}
    header = json.loads(bytes(arrays["header"]))
    header["format_version"] = 99
    arrays["header"] = np.frombuffer(json.dumps(header).encode(), np.uint8)
    with open(path, "wb") as f:
        np.savez(f, **arrays)
    with pytest.raises(InputError, match=r"format version 99.*reads version 1"):
        SpreadletDatabase.load(path)


def test_inconsistent_arrays_are_refused(db):
    offsets = db.dense_offsets.copy()
    offsets[1] += 1  # same total, wrong split
    with pytest.raises(InputError, match="dense_offsets: must be the cumulative sum"):
        SpreadletDatabase(db.model, db.params, db.grid, db.channels, db.psf_resolution, db.C, db.P, db.V,
                          db.fast_track, db.dense_radius, offsets, db.dense_values, db.stats)
    c = db.C.copy()
    c[1] = c[-1] + 1  # decreases afterwards
    with pytest.raises(InputError, match="array C: must start at 0 and never decrease"):
        SpreadletDatabase(db.model, db.params, db.grid, db.channels, db.psf_resolution, c, db.P,
                          db.V, db.fast_track, db.dense_radius, db.dense_offsets, db.dense_values, db.stats)
    with pytest.raises(InputError, match="stats: missing"):
        SpreadletDatabase(db.model, db.params, db.grid, db.channels, db.psf_resolution, db.C, db.P, db.V,
                          db.fast_track, db.dense_radius, db.dense_offsets, db.dense_values, {})
    bad = db.V.copy()
    bad[0, 0] = np.nan
    with pytest.raises(InputError, match="V: contains NaN"):
        SpreadletDatabase(db.model, db.params, db.grid, db.channels, db.psf_resolution, db.C, db.P, bad,
                          db.fast_track, db.dense_radius, db.dense_offsets, db.dense_values, db.stats)


def test_builder_checks_its_input():
    grid = NestedGrid.for_samples(3, (2.0,), [(0, 4)], ["coc"])
    b = DatabaseBuilder("simple_lens", {}, grid, 1, 9)
    with pytest.raises(InputError, match="32767"):
        b.add([[40000, 0]], [1.0], np.ones((1, 1)), stats=STATS)
    with pytest.raises(InputError, match=r"dense crop.*2r\+1"):
        b.add([[0, 0]], [1.0], np.ones((2, 2)), stats=STATS)
    b.add([[0, 0]], [1.0], np.ones((1, 1)), stats=STATS)
    with pytest.raises(InputError, match="differ from earlier"):
        b.add([[0, 0]], [1.0], np.ones((1, 1)), stats={"sparsity": 1.0})
    with pytest.raises(InputError, match="1 samples added, the grid has 3"):
        b.build()
