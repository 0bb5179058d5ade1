"""Helpers for the precompute tests: small SimpleLens jobs (a few PSFs, few rays, tiny images)."""
import copy

import numpy as np

from runtime_cl.psf.database import ARRAYS, SpreadletDatabase

# 10 cells, 17^2 PSFs, 2^15 rays each: the whole job takes well under a second once compiled.
SMALL = {"max_coc_px": 6.0, "samples": 10, "psf_resolution": 17, "rays_per_psf": 2 ** 15,
         "rays_per_pixel": 256, "rays_per_launch": 2 ** 15}


def small_sets(table=SMALL) -> list[str]:
    """``--set`` arguments for ``table``."""
    return [f"{k}={v}" for k, v in table.items()]


def cli_sets(table=SMALL) -> list[str]:
    """``--set KEY=VALUE`` command-line arguments for ``table``."""
    return [a for item in small_sets(table) for a in ("--set", item)]


def small_model(**changes):
    from lab.psf_tracing.models import load_model

    return load_model("simple_lens", {**SMALL, **changes})


def assert_same_database(a: SpreadletDatabase, b: SpreadletDatabase) -> None:
    """Bitwise the same content: every array, every statistic and the header.

    The header's ``params.hash`` names the code version too; other work on the tree between two
    builds of one test session changes it without changing these samples, so it is compared (with
    the whole-file checksum) only when both builds ran the same code.
    """
    for name, _ in ARRAYS:
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)
    assert sorted(a.stats) == sorted(b.stats)
    for name in a.stats:
        np.testing.assert_array_equal(a.stats[name], b.stats[name], err_msg=name)
    ha, hb = copy.deepcopy(a.header()), copy.deepcopy(b.header())
    same_code = ha["params"].pop("hash") == hb["params"].pop("hash")
    assert ha == hb
    if same_code:
        assert a.compute_checksum() == b.compute_checksum()


def small_cells() -> int:
    return small_model().grid.size
