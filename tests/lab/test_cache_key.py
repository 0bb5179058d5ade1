"""Content-keyed caches: keys follow the code a result imports, not paths or hand-kept lists."""
import shutil
from pathlib import Path

import pytest

from lab.cache_key import code_digest, module_files
from lab.paths import ROOT, SCENES
from lab.pipeline import RENDER_ROOTS, render_key
from lab.precompute.naming import code_roots
from lab.scene import load_scene


@pytest.fixture(scope="module")
def tree(tmp_path_factory):
    """A copy of lab/ and runtime_cl/ that a test may edit; returns a function giving its packages."""
    base = tmp_path_factory.mktemp("tree")

    def copy(name="copy"):
        target = base / name
        if not target.exists():
            for pkg in ("lab", "runtime_cl"):
                shutil.copytree(ROOT / pkg, target / pkg, ignore=shutil.ignore_patterns("__pycache__"))
        return {"lab": target / "lab", "runtime_cl": target / "runtime_cl"}
    return copy


def _edit(path: Path):
    path.write_text(path.read_text() + "\n# edited\n")


def test_a_database_key_ignores_scheduling_and_follows_lazy_imports():
    files = module_files(code_roots("simple_lens"))
    assert "lab.precompute.executors" not in files and "lab.cli" not in files
    # imported inside functions only: still part of the key
    assert {"lab.sparsify.spreadlets", "lab.psf_tracing.models", "runtime_cl.psf.database"} <= set(files)


def test_the_same_code_elsewhere_keeps_its_key(tree):
    roots = code_roots("simple_lens")
    assert code_digest(roots, tree()) == code_digest(roots)


def test_moving_a_module_keeps_the_key(tmp_path):
    pkg = tmp_path / "one" / "pkg"
    (pkg / "sub").mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "sub" / "__init__.py").write_text("")
    (pkg / "sub" / "a.py").write_text("def f():\n    from . import b\n    return b.g()\n")
    (pkg / "sub" / "b.py").write_text("def g():\n    return 1\n")
    before = code_digest(["pkg.sub.a"], {"pkg": pkg})
    moved = tmp_path / "two" / "pkg"
    shutil.copytree(pkg, moved)
    (moved / "sub").rename(moved / "deeper")
    assert set(module_files(["pkg.deeper.a"], {"pkg": moved})) == {"pkg.deeper.a", "pkg.deeper.b"}
    assert code_digest(["pkg.deeper.a"], {"pkg": moved}) == before
    _edit(moved / "deeper" / "b.py")
    assert code_digest(["pkg.deeper.a"], {"pkg": moved}) != before


def test_editing_polygon_code_keeps_the_spreadlet_database_key(tree):
    packages = tree("polygon")
    roots = code_roots("simple_lens")
    before = code_digest(roots, packages)
    # the outlines (runtime_cl/polygon/shapes.py) are also the traced heart and star apertures'
    shapes = packages["runtime_cl"] / "polygon" / "shapes.py"
    edited = [f for f in sorted((packages["runtime_cl"] / "polygon").glob("*.py")) if f != shapes]
    edited += sorted((packages["lab"] / "polygon").glob("*.py")) + [packages["lab"] / "polygon_aperture.py"]
    assert len(edited) > 10
    for f in edited:
        _edit(f)
    assert code_digest(roots, packages) == before
    _edit(shapes)
    changed = code_digest(roots, packages)
    assert changed != before
    _edit(packages["runtime_cl"] / "psf" / "database.py")
    assert code_digest(roots, packages) != changed


def test_editing_the_iris_changes_the_polygon_reference_key(tree):
    packages = tree("iris")
    scene = load_scene(SCENES / "occlusion.toml")
    before = render_key(scene, packages)
    assert "lab.optics.iris" in module_files(RENDER_ROOTS, packages)
    _edit(packages["lab"] / "optics" / "iris.py")
    assert render_key(scene, packages) != before


def test_editing_the_runtime_or_the_tracer_keeps_the_render_key(tree):
    """RENDER_EXCLUDE: the runtime's passes and the PSF tracer do not draw references or inputs
    (tests/lab/reference/test_render_key_exclusions.py shows that none of their code runs), so
    editing them keeps cached renders; editing what renders (the reference's CoC) does not."""
    packages = tree("runtime")
    scene = load_scene(SCENES / "tiny.toml")
    before = render_key(scene, packages)
    for rel in ("runtime_cl/passes/spreadlets.py", "runtime_cl/layered/tracer.py", "runtime_cl/spreadlets/renderer.py",
                "lab/psf_tracing/models/volume.py", "lab/psf_tracing/tracer.py", "lab/runtime_passes.py"):
        _edit(packages[rel.partition("/")[0]].parent / rel)
    assert render_key(scene, packages) == before
    _edit(packages["lab"] / "reference" / "coc.py")
    assert render_key(scene, packages) != before
