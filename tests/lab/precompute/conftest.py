"""Fixtures: private caches and the reference (serial, uninterrupted) run of the SMALL job."""
import pytest

from precompute_helpers import small_cells, small_model
from runtime_cl.psf.database import SpreadletDatabase


@pytest.fixture
def cache(tmp_path, monkeypatch):
    """A private, empty cache for one test."""
    root = tmp_path / "cache"
    monkeypatch.setenv("SPLATLAB_CACHE", str(root))
    return root


@pytest.fixture(scope="session")
def reference(tmp_path_factory):
    """The SMALL job run serially, uninterrupted: (database, its cache folder)."""
    from lab.precompute import precompute

    root = tmp_path_factory.mktemp("reference-cache")
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("SPLATLAB_CACHE", str(root))
        result = precompute(small_model(), progress=False)
    assert not result.reused and result.cells == small_cells()
    return SpreadletDatabase.load(result.path, expect_model="simple_lens"), root
