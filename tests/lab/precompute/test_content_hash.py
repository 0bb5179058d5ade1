"""Content-hash naming: an unchanged configuration is reused, a changed one rebuilt."""
import tracemalloc

from lab.precompute import content_hash, precompute, source_digest
from runtime_cl.psf.database import SpreadletDatabase

from precompute_helpers import assert_same_database, small_model


def test_hash_covers_model_config_and_code():
    model = small_model()
    code = source_digest("simple_lens")
    h = content_hash("simple_lens", model.config, code)
    assert h == content_hash("simple_lens", small_model().config, code)
    assert len(h) == 12 and int(h, 16) >= 0
    assert h != content_hash("simple_lens", small_model(seed=1).config, code)
    assert h != content_hash("simple_lens", small_model(density=0.5).config, code)
    assert h != content_hash("other_model", model.config, code)
    assert h != content_hash("simple_lens", model.config, "0" * 64)


def test_unchanged_config_is_reused_and_a_changed_one_rebuilt(reference, cache):
    ref, _ = reference
    first = precompute(small_model(), progress=False)
    assert not first.reused and first.cells > 0
    stamp = first.path.stat().st_mtime_ns
    again = precompute(small_model(), progress=False)
    assert again.reused and again.path == first.path and again.rays == 0 and again.cells == 0
    assert first.path.stat().st_mtime_ns == stamp  # not rewritten
    changed = precompute(small_model(seed=1), progress=False)
    assert not changed.reused and changed.path != first.path and changed.cells == first.cells
    assert first.path.exists()  # the old configuration's database stays cached
    a, b = SpreadletDatabase.load(first.path), SpreadletDatabase.load(changed.path)
    assert a.params["config"]["seed"] == 0 and b.params["config"]["seed"] == 1
    assert a.compute_checksum() != b.compute_checksum()
    forced = precompute(small_model(), progress=False, force=True)
    assert not forced.reused and forced.cells == first.cells
    assert_same_database(SpreadletDatabase.load(forced.path), ref)


def test_memory_stays_bounded_as_shards_stream(cache):
    """105 PSFs of 129^2 float32 (7 MB if all were held) on numpy's traced heap: the job peaks
    at a per-PSF working set plus the small dense crops the database stores."""
    model = small_model(max_coc_px=3.0, samples=100, psf_resolution=129, rays_per_psf=2 ** 12,
                        rays_per_launch=2 ** 12, rays_per_pixel=64)
    model.trace_checked(model.grid.size - 1)  # compile outside the measurement
    all_psfs = model.grid.size * model.resolution ** 2 * 4
    tracemalloc.start()
    try:
        result = precompute(model, progress=False)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert result.cells == model.grid.size >= 100
    assert peak < all_psfs / 2, (peak, all_psfs)
