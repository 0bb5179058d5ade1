"""The end-to-end pipeline at tiny resolution, run once per test session in a private cache."""
from pathlib import Path

import pytest

from lab.paths import SCENES

TINY = SCENES / "tiny.toml"


@pytest.fixture(scope="session")
def e2e_cache(tmp_path_factory):
    return tmp_path_factory.mktemp("cache")


@pytest.fixture(scope="session")
def tiny_report(e2e_cache, tmp_path_factory):
    """Run `splatlab report scenes/tiny.toml` in-process (cold cache); return (report, out_dir)."""
    mp = pytest.MonkeyPatch()
    mp.setenv("SPLATLAB_CACHE", str(e2e_cache))
    from lab.pipeline import run_report

    out = tmp_path_factory.mktemp("report")
    report = run_report(TINY, out, progress=False)
    yield report, out
    mp.undo()


@pytest.fixture(scope="session")
def tiny_db(tiny_report):
    report, _ = tiny_report
    return Path(report["database"]["simple_lens"]["path"])


@pytest.fixture(scope="session")
def tiny_input(tiny_report, e2e_cache):
    """The labelled-pixel EXR the report used (from the render cache)."""
    (path,) = sorted(Path(e2e_cache, "renders").glob("*/input.exr"))
    return path
