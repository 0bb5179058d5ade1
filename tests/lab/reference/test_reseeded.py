"""Renders compared with the reference (its noise-floor twin, the path tracer as a sweep or bench
method) draw samples the reference never drew: a render at fewer spp from the reference's own seed
is a prefix of its passes, so it would agree with it far better than independent noise does."""
from lab.paths import SCENES
from lab.pipeline import reseeded
from lab.reference.passes import pass_seeds, split_spp
from lab.scene import load_scene


def _seeds(scene, spp):
    w, h = scene.info.resolution
    return set(pass_seeds(scene.render.seed, "reference", len(split_spp(spp, w, h))))


def test_same_seed_reuses_the_references_passes():
    # why the helper exists: fewer spp from the same seed are the reference's first passes
    scene = load_scene(SCENES / "foreground.toml")
    assert _seeds(scene, 1024) <= _seeds(scene, scene.render.reference_spp)


def test_reseeded_streams_share_no_pass_with_the_reference_or_each_other():
    scene = load_scene(SCENES / "foreground.toml")
    ref = _seeds(scene, scene.render.reference_spp)
    twin, method = reseeded(scene, 1), reseeded(scene, 2, reference_spp=1024)
    assert method.render.reference_spp == 1024 and twin.render.reference_spp == scene.render.reference_spp
    assert not ref & _seeds(twin, scene.render.reference_spp)
    assert not ref & _seeds(method, 1024)
    assert not _seeds(twin, scene.render.reference_spp) & _seeds(method, 1024)
