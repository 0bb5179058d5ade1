"""The fence scene of ``splatlab bench layer_cost``: peeled as LES10 peels, ever sparser layers."""
import numpy as np

from lab.bench.layer_cost import fence_layers
from lab.reference.peel import umbra_offset
from runtime_cl.camera.thin_lens import ThinLens


def test_fence_layers_are_peeled_past_the_umbra():
    camera = ThinLens(focal_length_mm=50.0, f_number=1.4, focus_distance_m=4.0)
    layers = fence_layers(camera, width=400, height=4, posts=30)
    occupancy = [float(np.mean(a > 0)) for _, a, _ in layers]
    assert occupancy[0] == 1.0 and all(b <= a for a, b in zip(occupancy[1:], occupancy[2:]))
    assert occupancy[4] > 0                                   # layers 5-8 exist
    scale = camera.coc_scale_px(400)
    for (_, _, near), (_, alpha, far) in zip(layers, layers[1:]):
        held = alpha > 0
        assert np.all(far[held] >= near[held] + umbra_offset(near[held], scale) - 1e-6)
        assert np.all(np.isinf(far[~held]))


def test_the_grids_fence_is_sixteen_layers_deep():
    # LES10 Table 1's 1 ... 16 layers: the grid's denser fence must reach its 16th layer
    camera = ThinLens(focal_length_mm=50.0, f_number=1.4, focus_distance_m=4.0)
    layers = fence_layers(camera, height=2, posts=300, n_layers=16)
    occupancy = [float(np.mean(a > 0)) for _, a, _ in layers]
    assert len(layers) == 16 and occupancy[0] == 1.0 and 0 < occupancy[15] < occupancy[8]
