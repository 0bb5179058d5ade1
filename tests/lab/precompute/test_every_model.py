"""Every registered PSF model goes through the same job: trace, sparsify, shards, database, atlas."""
import numpy as np
import pytest

from lab.precompute import precompute
from lab.psf_tracing.models import load_model, model_names
from lab.report.atlas import render_atlas
from lab.report.table1 import table1_row
from runtime_cl.psf.database import SpreadletDatabase

from precompute_helpers import SMALL

_RAYS = {"rays_per_psf": 2 ** 14, "rays_per_launch": 2 ** 14}
# Tiny settings per model (a few PSFs, few rays); seconds each once compiled.
TINY = {
    "simple_lens": SMALL,
    "combined": {"max_coc_px": 4.0, "max_motion_px": 6.0, "samples": 10, "psf_resolution": 21,
                 "rays_per_pixel": 64, **_RAYS},
    "stylized": {"max_coc_px": 6.0, "samples": 10, "psf_resolution": 21, "rays_per_pixel": 64, **_RAYS},
    "physical_lens": {"samples": 10, "psf_resolution": 181, "rays_per_pixel": 16, **_RAYS},
    "volume": {"samples": 10, "psf_resolution": 63, **_RAYS},
    "volume_box": {"samples": 20, "psf_resolution": 63, **_RAYS},
    "volume_far": {"samples": 10, "psf_resolution": 33, "pixel_scale": 5, "hole_half_px": 14, **_RAYS},
}


def _check_job(name, cache):
    model = load_model(name, TINY[name])
    result = precompute(model, progress=False)
    db = SpreadletDatabase.load(result.path, expect_model=name)
    assert db.n_samples == model.grid.size == result.cells
    assert db.channels == model.channels and db.grid.ns == model.grid.ns
    assert db.params["symmetries"] == list(model.symmetries)
    for i in range(db.n_samples):  # a dense PSF sums to the light that reaches the image per channel:
        sums = db.dense_psf(i).sum(axis=(0, 1))    # 1 for a lens, the medium's energy for a volume
        if "energy" in db.stats:
            assert np.all((sums > 0) & (sums <= 1)) and np.mean(sums) == pytest.approx(db.stats["energy"][i], rel=1e-4)
        else:
            np.testing.assert_allclose(sums, 1.0, rtol=1e-4)
    assert db.basis == model.basis
    if db.basis == "dual":   # the same PSFs again as row differences, each drawing its dense PSF
        for i in np.flatnonzero(~db.row_fast):
            p, v = db.row_spreadlets(i)
            image = np.zeros((2 * db.pad + 1, 2 * db.pad + 2, db.channels))
            np.add.at(image, (p[:, 1] + db.pad, p[:, 0] + db.pad), v)
            drawn, dense = np.cumsum(image, axis=1), db.dense_psf(i)
            r = dense.shape[0] // 2
            crop = drawn[db.pad - r:db.pad + r + 1, db.pad - r:db.pad + r + 1]
            assert np.abs(crop - dense).sum() <= 0.3 * np.abs(dense).sum()
        assert "row_sparsity" in db.stats and db.info()["row_spreadlets"] == int(db.row_C[-1])
    img, cells = render_atlas(db, columns=4, blocks=2)
    assert len(cells) >= 3 and np.asarray(img).std() > 10
    row = table1_row(db)
    assert row["samples"] == db.n_samples and 0 < row["mean_sparsity_percent"] <= 100
    assert 0 < row["mean_similarity_ssim"] <= 1
    again = precompute(model, progress=False)
    assert again.reused and again.path == result.path


@pytest.mark.parametrize("name", ["combined", "stylized"])
def test_two_dimensional_and_rgb_models(name, cache):
    if name not in model_names():
        pytest.skip(f"model {name} is not registered")
    _check_job(name, cache)


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(TINY))
def test_every_registered_model(name, cache):
    assert set(model_names()) <= set(TINY), "add tiny settings for the new model to TINY"
    if name not in model_names():
        pytest.skip(f"model {name} is not registered")
    _check_job(name, cache)
