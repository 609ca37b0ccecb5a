"""The presets of the papers' comparison figures (power weights, cheap former paths, the fractal grid, widths
by path cost): each shows the phenomenon its figure shows, is reproducible, and refuses bad input by name."""

import numpy as np
import pytest
from scipy.sparse.csgraph import dijkstra

from wdendrite import cli, presets

SMALL = {
    "power_weights": lambda s: presets.power_weights((64, 64), endpoints=10, seed=s),
    "cheap_paths": lambda s: presets.cheap_paths((80, 80), added=12, seed=s),
    "fractal_grid": lambda s: presets.fractal_grid(48, alphas=(2.0, 1.2), betas=(2.0,), seed=s),
    "width_demo": lambda s: presets.width_demo((64, 40), seed=s),
    "taper_demo": lambda s: presets.taper_demo((64, 64), endpoints=3, seed=s),
    "weight_distributions": lambda s: presets.weight_distributions((48, 48), endpoints=5, seed=s),
}


@pytest.mark.parametrize("name", sorted(SMALL))
def test_figure_presets_are_reproducible_and_labelled(name):
    a, b = SMALL[name](3), SMALL[name](3)
    np.testing.assert_array_equal(a.image, b.image)
    np.testing.assert_array_equal(a.dendrite.nodes, b.dendrite.nodes)
    assert a.image.dtype == np.float32 and 0 <= a.image.min() and a.image.max() <= 1
    # a white strip holding dark text above the panels: their labels
    strip = a.image[:10]
    assert strip.max() == 1.0 and strip.min() < 0.5
    assert not np.array_equal(SMALL[name](4).image, a.image)


def _tortuosity(den):
    """Mean over endpoints of the drawn path's length over the straight distance to the root."""
    out = []
    for e in den.endpoints:
        p = den.nodes[den.path(int(e))].astype(float)
        out.append(np.linalg.norm(np.diff(p, axis=0), axis=1).sum() / np.linalg.norm(p[-1] - p[0]))
    return np.mean(out)


def test_power_weights_straighten_for_small_alpha_and_wander_for_large():
    res = presets.power_weights(seed=0)  # the paper's alphas, 0.3, 1 and 3
    dens = res.parts["dendrites"]
    assert list(dens) == [0.3, 1.0, 3.0]
    ends = [d.nodes[d.endpoints] for d in dens.values()]
    assert all(np.array_equal(np.sort(e, axis=0), np.sort(ends[0], axis=0)) for e in ends)  # the same endpoints
    assert all(d.nodes[d.roots[0]].tolist() == [198, 100] for d in dens.values())  # the root at the bottom
    t = [_tortuosity(d) for d in dens.values()]
    # "nearly straight lines" at 0.3 (octile steps alone make up to 1.08); "more erratic" at 3
    assert t[0] < 1.12 and 1.2 < t[1] < t[2] - 0.2, t


def test_cheaper_former_paths_draw_later_paths_onto_them():
    res = presets.cheap_paths(seed=0)  # the thesis' D = 1, 0.8, 0.6, 0.3
    dens = res.parts["dendrites"]
    assert list(dens) == [1.0, 0.8, 0.6, 0.3]
    former = [d.nodes[d.generation == 0] for d in dens.values()]
    assert all(np.array_equal(f, former[0]) for f in former)  # the same former paths in every panel
    added = [np.sort(d.nodes[d.endpoints[d.generation[d.endpoints] > 0]], axis=0) for d in dens.values()]
    assert all(np.array_equal(a, added[0]) for a in added)  # and the same later endpoints
    # the cheaper the former edges, the sooner the later paths join them: fewer new nodes
    # (seeds 0, 1, 2: 1004 > 963 > 840 > 808, 1001 > 883 > 867 > 829, 1359 > 1167 > 1142 > 948)
    new = [int((d.generation > 0).sum()) for d in dens.values()]
    assert new[0] > 1.15 * new[-1] and all(a >= b for a, b in zip(new, new[1:])), new


def test_the_fractal_grid_starts_every_panel_at_one_cost_so_alpha_shows():
    res = presets.fractal_grid(120, betas=(3.0,), seed=1)  # alphas 2, 1.5, 1.2 (thesis Fig. 3.13)
    dens = res.parts["dendrites"]
    reach = []
    for (a, b), den in dens.items():
        assert den.generation.max() == 2  # "All dendrites were built with three iterations"
        first = den.nodes[den.endpoints[den.generation[den.endpoints] == 0]]
        centre = den.nodes[den.roots[0]]
        reach.append(np.sqrt(((den.nodes - centre) ** 2).sum(1)).max())
        # the first endpoints lie at the same path cost d in every panel
        cost = den.cost[den.endpoints[den.generation[den.endpoints] == 0]]
        np.testing.assert_allclose(cost, res.parts["d"], rtol=0.11)
        assert len(first) == 4
    assert reach[0] < reach[1] < reach[2], reach  # smaller alpha, later endpoints farther out


@pytest.mark.parametrize("name", ["width_demo", "taper_demo"])
def test_width_figures_fall_off_with_scipy_path_costs(name):
    res = SMALL[name](0)
    lat = res.parts["lattices"][0] if name == "width_demo" else res.parts["lattice"]
    den = res.dendrite
    d = dijkstra(lat.to_csgraph(), indices=np.ravel_multi_index(tuple(den.nodes.T), den.shape), min_only=True)
    d = d.reshape(den.shape)
    v = res.parts["values"][0]  # constant T = 5.0 path cost units in both figures
    np.testing.assert_allclose(v, np.where(d <= 15.0, np.exp(-((d / 5.0) ** 2)), 0.0), atol=1e-5)
    if name == "width_demo":
        wide, narrow = (np.count_nonzero(x > 0.5) for x in res.parts["values"][:2])
        assert wide > 1.5 * narrow


@pytest.mark.parametrize("args, words", [
    (["power-weights", "--size", "32", "--alphas", "0,1"], ["'alphas' > 0, but got 0.0 (--alphas)"]),
    (["power-weights", "--size", "32", "--connectivity", "6"], ["'connectivity' 4 or 8"]),
    (["power-weights", "--size", "16", "--endpoints", "500"], ["'endpoints' = 500 is more than fit above the root"]),
    (["cheap-paths", "--size", "32", "--factors", "0.5,0"], ["'factors' in (0, 1]", "0.0"]),
    (["cheap-paths", "--size", "32", "--factors", "1,1.5"], ["'factors' in (0, 1]", "1.5"]),
    (["cheap-paths", "--size", "32", "--added", "0"], ["'added' >= 1"]),
    (["fractal-grid", "--cell", "32", "--alphas", "1.5,1"], ["'alphas' > 1", "got 1.0 (--alphas)"]),
    (["width-demo", "--size", "4"], ["'shape'"]),
])
def test_figure_presets_refuse_bad_input_by_name_and_write_nothing(args, words, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert cli.main([*args, "-o", "fig.png", "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err
    for w in words:
        assert w in err, (w, err)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("func, kw, match", [
    (presets.power_weights, dict(shape=(32, 32), alphas=()), "'alphas' as a non-empty list"),
    (presets.power_weights, dict(shape=(32, 32), alphas=(1.0, 1)), "'alphas' lists 1 twice"),
    (presets.cheap_paths, dict(shape=(32, 32), factors=(0.5, 0.5)), "'factors' lists 0.5 twice"),
    (presets.cheap_paths, dict(shape=(32, 32), former=0), "'former'"),
])
def test_figure_presets_check_their_lists_before_any_kernel(func, kw, match, launches):
    with pytest.raises(ValueError, match=match):
        func(**kw)
    assert launches == []
