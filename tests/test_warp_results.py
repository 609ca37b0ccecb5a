"""Fields kept on their device: a CostField's ``*_array`` and ``as_warp=True`` return the Warp arrays
the kernels wrote, equal to the NumPy results, so GPU pipelines skip the copy to the host."""

import numpy as np
import pytest
import warp as wp

import wdendrite as wd

TABLE1 = dict(domain=((0.0, 0.0), (4.0, 4.0)), control=wd.control.perlin(seed=0, domain=((-0.2, -0.4), (1.4, 0.7))),
              params=wd.DendryParams(levels=2, eps=0.25, delta=0.1, beta=0.5, noise=0.05, seed=3))


def _on(arr, device, shape, dtype):
    assert isinstance(arr, wp.array), type(arr)
    assert arr.shape == shape and arr.dtype == dtype and str(arr.device) == device


def test_a_cost_field_holds_its_costs_and_labels_as_device_arrays(device):
    lat = wd.Lattice((9, 11), 8, weights=wd.weights.Uniform(r=10, seed=1))
    cf = wd.shortest_paths(lat, [[4, 5], [0, 0]], device=device)
    _on(cf.dist_array, device, (9, 11), wp.float32)
    _on(cf.label_array, device, (9, 11), wp.int32)
    np.testing.assert_array_equal(cf.dist_array.numpy(), cf.dist)
    np.testing.assert_array_equal(cf.label_array.numpy(), cf.label)
    assert set(np.unique(cf.label)) == {0, 1} and cf.dist[4, 5] == 0 == cf.dist[0, 0]


@pytest.mark.parametrize("metric, lattice", [("euclidean", None), ("path", None), ("path", "weighted")])
def test_brightness_as_warp_is_the_image_on_the_device(device, metric, lattice):
    lat = wd.Lattice((24, 30), 8, weights=wd.weights.Uniform(r=10, seed=2))
    den = wd.trace(wd.shortest_paths(lat, [[12, 15]], device=device), [[0, 0], [23, 29], [0, 29]])
    kw = dict(metric=metric, lattice=lat if lattice else None, device=device)
    image = wd.render.brightness(den, 2.0, **kw)
    kept = wd.render.brightness(den, 2.0, as_warp=True, **kw)
    _on(kept, device, (24, 30), wp.float32)
    np.testing.assert_array_equal(kept.numpy(), image)
    assert image.max() == 1.0  # (on the dendrite)


@pytest.mark.parametrize("output, mode, window", [("elevation", "cached", None), ("distance", "pixel", (3, 5, 9, 7)),
                                                  ("level", "auto", (0, 0, 16, 16))])
def test_dendry_as_warp_is_the_image_on_the_device(device, output, mode, window):
    kw = dict(TABLE1, output=output, mode=mode, window=window, device=device)
    image = wd.dendry((16, 16), **kw)
    kept = wd.dendry((16, 16), as_warp=True, **kw)
    _on(kept, device, image.shape, wp.float32)
    np.testing.assert_array_equal(kept.numpy(), image)


SMALL = wd.trace(wd.shortest_paths(wd.Lattice((6, 6)), [[0, 0]]), [[5, 5]])


@pytest.mark.parametrize("call", [lambda: wd.dendry((8, 8), as_warp="yes", **TABLE1),
                                  lambda: wd.render.brightness(SMALL, 2.0, as_warp=1)], ids=["dendry", "brightness"])
def test_as_warp_takes_a_bool_only(call, launches):
    with pytest.raises(TypeError, match=r"Expected a bool for 'as_warp', but got"):
        call()
    assert launches == []  # (refused before any kernel ran)
