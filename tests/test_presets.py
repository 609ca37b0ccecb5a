"""Presets at small sizes: every model runs, is reproducible from its seed, and has the papers' properties."""

import numpy as np
import pytest

from wdendrite import presets
from wdendrite.geometry import surface_nodes
from wdendrite.presets import LightningParams, Result

SMALL_2D = {
    "simple_dendrite": lambda s: presets.simple_dendrite((64, 64), endpoints=5, seed=s),
    "fractal_grid": lambda s: presets.fractal_grid(40, alphas=(2.0, 1.5), betas=(2.0, 3.0), seed=s),
    "dla_imitation": lambda s: presets.dla_imitation((80, 80), seed=s),
    "weight_distributions": lambda s: presets.weight_distributions((48, 48), endpoints=5, seed=s),
    "tropisms": lambda s: presets.tropisms((48, 48), endpoints=5, seed=s),
    "competition": lambda s: presets.competition((64, 64), seed=s),
    "letters": lambda s: presets.letters("Hi", height=40, seed=s),
    "lightning": lambda s: presets.lightning((96, 96), params=LightningParams(forks=3, minor_forks=3), seed=s),
    "width_demo": lambda s: presets.width_demo((64, 40), seed=s),
    "taper_demo": lambda s: presets.taper_demo((64, 64), endpoints=3, seed=s),
}
SMALL_3D = {
    "elm_tree": lambda s: presets.elm_tree((24, 24, 24), endpoints=5, seed=s),
    "tropism_objects": lambda s: presets.tropism_objects((20, 20, 20), toward=("axis", "top"), endpoints=5, seed=s),
    "staghorn_coral": lambda s: presets.staghorn_coral((16, 16, 16), endpoints=4, refine_n=3, seed=s),
    "rock": lambda s: presets.rock((24, 24, 24), seed=s),
    "lichen_on_rock": lambda s: presets.lichen_on_rock((32, 32, 32), count=3, seed=s),
    "moss": lambda s: presets.moss((12, 24, 24), endpoints=20, seed=s),
}
CACHE = {}


def run(name, seed=1):
    key = (name, seed)
    if key not in CACHE:
        CACHE[key] = {**SMALL_2D, **SMALL_3D}[name](seed)
    return CACHE[key]


@pytest.mark.parametrize("name", sorted({**SMALL_2D, **SMALL_3D}))
def test_preset_returns_a_picture_and_is_reproducible(name):
    res = run(name)
    assert isinstance(res, Result)
    img = res.image
    assert img.ndim == 3 and img.shape[2] == 3 and img.dtype == np.float32
    assert 0.0 <= img.min() and img.max() <= 1.0
    assert img.std() > 0.01  # not blank
    again = {**SMALL_2D, **SMALL_3D}[name](1)
    np.testing.assert_array_equal(again.image, img)
    if res.dendrite is not None:
        np.testing.assert_array_equal(again.dendrite.nodes, res.dendrite.nodes)
    if name in SMALL_3D:
        assert res.mesh is not None and len(res.mesh.faces) > 0
    # a short summary, not the picture's values (nor every node's), and identity equality (== had raised)
    assert len(repr(res)) < 400 and f"image={img.shape} float32" in repr(res)
    assert res == res and res != again and len({res, again}) == 2


def test_lightning_main_stroke_runs_from_the_top_to_the_bottom():
    res = run("lightning")
    den, main = res.dendrite, res.parts["main"]
    assert den.nodes[den.roots, 0].max() <= 3
    assert main.nodes[:, 0].max() >= 96 - 4
    # the channel is bright, the sky between branches dark; both graphs hold branches
    v = res.parts["value"]
    assert np.all(v[tuple(main.nodes.T)] > 0.99)
    assert (v > 0.5).mean() < 0.3
    assert set(np.unique(res.parts["graph"])) == {0, 1, 2}


def test_competing_dendrites_never_share_a_node():
    den = run("competition").dendrite
    assert set(np.unique(den.label)) == {0, 1}
    a = den.nodes[den.label == 0]
    b = den.nodes[den.label == 1]
    assert not ({tuple(p) for p in a} & {tuple(p) for p in b})


@pytest.mark.parametrize("seed", [3, 4, 5, 6, 8, 10, 15])
def test_competition_guarantees_what_it_says_over_seeds(seed):
    # at these seeds nodes of the two dendrites lie side by side: the docstring had said they never touch
    doc = " ".join(presets.competition.__doc__.split())
    assert "never touch" not in doc and "never share a node" in doc
    den = presets.competition((64, 64), seed=seed).dendrite
    assert sorted(den.label[den.roots].tolist()) == [0, 1]
    # one node, one dendrite: no coordinates twice, and every branch stays in its generator's dendrite
    assert len({tuple(p) for p in den.nodes.tolist()}) == len(den)
    child = np.flatnonzero(den.parent >= 0)
    np.testing.assert_array_equal(den.label[child], den.label[den.parent[child]])
    for row in range(len(den)):
        assert den.label[den.path(row)[-1]] == den.label[row]


def test_letter_paths_stay_inside_the_letters():
    res = run("letters")
    mask = res.parts["mask"]
    assert mask[tuple(res.dendrite.nodes.T)].all()
    custom = np.zeros((30, 30), bool)
    custom[5:25, 10:14] = True
    bar = presets.letters(mask=custom, seed=0)
    assert custom[tuple(bar.dendrite.nodes.T)].all()


def test_lichen_never_enters_the_rock_and_rock_mesh_is_closed():
    res = run("lichen_on_rock")
    inside = res.parts["costfield"].label == 0
    surf = np.zeros_like(inside)
    surf[tuple(surface_nodes(inside).T)] = True
    interior = inside & ~surf
    assert surf[tuple(res.dendrite.nodes.T)].all()  # (on_rock: the paths keep to the surface)
    free = presets.lichen_on_rock((32, 32, 32), count=3, on_rock=False, seed=1).dendrite
    assert not interior[tuple(free.nodes.T)].any()
    assert surf[tuple(free.nodes[free.endpoints].T)].all()
    assert res.mesh.is_watertight and len(res.mesh.split(only_watertight=False)) == 1
    rock = run("rock")
    assert rock.mesh.is_watertight and rock.mesh.volume > 0


def test_moss_grows_from_the_plane_and_trees_from_their_root():
    den = run("moss").dendrite
    assert np.all(den.nodes[den.roots, 0] == 0)
    elm = run("elm_tree")
    assert elm.dendrite.nodes[elm.dendrite.roots].tolist() == [[1, 12, 12]]
    assert elm.mesh.is_watertight


def test_weight_distributions_n0_gives_straight_runs():
    dens = run("weight_distributions").parts["dendrites"]
    assert set(dens) == {0, 1, 4, 8}
    steps = {}
    for n, den in dens.items():
        child = np.flatnonzero(den.parent >= 0)
        # direction changes along paths: none but a few corners for n = 0, many for erratic weights
        turns = 0
        for p in den.paths():
            d = np.diff(den.nodes[p], axis=0)
            turns += int(np.any(d[1:] != d[:-1], axis=1).sum())
        steps[n] = turns / max(len(child), 1)
    assert steps[0] < steps[1] < steps[8]


def test_coral_is_refined():
    res = run("staghorn_coral")
    assert res.dendrite.spacing == pytest.approx(1 / 3)
    assert len(res.dendrite) > len(res.parts["coarse"])


@pytest.mark.parametrize(
    "call, match",
    [
        (lambda: presets.simple_dendrite((4, 4)), "shape"),
        (lambda: presets.simple_dendrite((10, 10, 10)), "2D"),
        (lambda: presets.elm_tree((30, 30)), "3D"),
        (lambda: presets.simple_dendrite((32, 32), endpoints=0), "endpoints"),
        (lambda: LightningParams(glow_radius=0), "glow_radius"),
        (lambda: LightningParams(minor_gain=2.0), "minor_gain"),
        (lambda: LightningParams(main_width=-1.0), "main_width"),
        # the weights' bound in the preset's own words: it has an 'alpha' but no 'max'
        (lambda: LightningParams(alpha=1e30), r"^'alpha' of the lightning's power weights .* got 1e\+30$"),
        (lambda: presets.letters(mask=np.zeros((10, 10), bool)), "non-empty"),
        # more forks than fit near the stroke: the parameter is named, not the endpoints' 'count'
        (lambda: presets.lightning((64, 64), params=LightningParams(forks=5000, minor_forks=0)), "'forks' = 5000"),
        (lambda: presets.lightning((64, 64), params=LightningParams(forks=2, minor_forks=5000)),
         "'minor_forks' = 5000"),
    ],
)
def test_bad_input(call, match):
    with pytest.raises(ValueError, match=match):
        call()


@pytest.mark.parametrize(
    "func, kw, match",
    [
        (presets.staghorn_coral, dict(shape=(16, 16, 16), refine_n=4), "refine_n"),
        (presets.staghorn_coral, dict(shape=(16, 16, 16), refine_n=1), "refine_n"),
        (presets.staghorn_coral, dict(shape=(16, 16, 16), refine_n=2.0), "refine_n"),
        (presets.simple_dendrite, dict(shape=(32, 32), endpoints=0), "endpoints"),
        (presets.elm_tree, dict(shape=(16, 16, 16), endpoints=0), "endpoints"),
        (presets.elm_tree, dict(shape=(16, 16, 16), geometry="cubes"), "geometry"),
        (presets.lichen_on_rock, dict(shape=(16, 16, 16), count=0), "count"),
        (presets.rock, dict(shape=(16, 16, 16), smooth=-1), "smooth"),
        (presets.rock, dict(shape=(16, 16, 16), smooth=10**12), r"'smooth' in \[0, 1000\]"),
        (presets.letters, dict(text="A", height=32, paths_per_1000=-1), "paths_per_1000"),
        (presets.fractal_grid, dict(cell=32, alphas=(2.0, 1.0)), "alpha"),
        (presets.dla_imitation, dict(shape=(32, 32), alpha=1), "alpha"),
        (presets.dla_imitation, dict(shape=(32, 32), beta=0.5), "beta"),
        (presets.dla_imitation, dict(shape=(32, 32), iterations=0), "iterations"),
        (presets.competition, dict(shape=(32, 32), count=0), "count"),
        (presets.taper_demo, dict(shape=(32, 32), endpoints=0), "endpoints"),
        (presets.moss, dict(shape=(16, 16, 16), endpoints=0), "endpoints"),
        (presets.tropism_objects, dict(shape=(16, 16, 16), toward=()), "'toward' as a non-empty list"),
        (presets.tropism_objects, dict(shape=(16, 16, 16), toward="axis"), "'toward' as a non-empty list"),
        (presets.tropism_objects, dict(shape=(16, 16, 16), toward=("axis", "up")), "'toward' in"),
        (presets.tropism_objects, dict(shape=(16, 16, 16), strength=-1.0), "'strength'"),
    ],
)
def test_bad_preset_values_raise_before_any_kernel(func, kw, match, launches):
    with pytest.raises(ValueError, match=match):
        func(**kw)
    assert launches == []


@pytest.mark.parametrize(
    "func, kw, exc, match",
    [
        # empty and scalar lists had raised bare IndexErrors and TypeErrors
        (presets.weight_distributions, dict(shape=(32, 32), ns=()), ValueError, r"'ns' as a non-empty list.*got \(\)"),
        (presets.weight_distributions, dict(shape=(32, 32), ns=2), TypeError, r"'ns' as a non-empty list.*got 2$"),
        (presets.tropisms, dict(shape=(32, 32), toward=()), ValueError, r"'toward' as a non-empty list.*got \(\)"),
        (presets.fractal_grid, dict(cell=32, alphas=()), ValueError, r"'alphas' as a non-empty list"),
        (presets.fractal_grid, dict(cell=32, betas=()), ValueError, r"'betas' as a non-empty list"),
        (presets.fractal_grid, dict(cell=32, alphas=2.0), TypeError, r"'alphas' as a non-empty list.*got 2.0"),
        (presets.fractal_grid, dict(cell=32, betas=np.array([[2.0]])), ValueError, r"'betas' as a non-empty list"),
        # one name is no list of names (its letters had been read as tropisms)
        (presets.tropisms, dict(shape=(32, 32), toward="left"), ValueError, r"'toward'.*the string 'left': a sequence"),
        (presets.tropism_objects, dict(shape=(16, 16, 16), toward="top"), ValueError, r"the string 'top': a sequence"),
        # a repeated entry had drawn two panels but kept one dendrite in parts["dendrites"]
        (presets.tropisms, dict(shape=(32, 32), toward=["left", "left"], roots=["right"]), ValueError,
         r"'toward' lists \('left', 'right'\) twice"),
        (presets.tropisms, dict(shape=(32, 32), toward=["left", "top"], roots=["left", "middle"]), ValueError,
         r"every entry of 'roots' in \('left', 'center', 'right'\), but got 'middle'"),
        (presets.tropisms, dict(shape=(32, 32), toward=["left", "top", "right"], roots=["left", "right"]), ValueError,
         r"one entry of 'roots' per entry of 'toward' \(3\), or one for all, but got 2"),
        (presets.tropism_objects, dict(shape=(16, 16, 16), toward=("axis", "top", "axis")), ValueError,
         r"'toward' lists 'axis' twice"),
        (presets.weight_distributions, dict(shape=(32, 32), ns=[1, 1]), ValueError, r"'ns' lists 1 twice"),
        (presets.weight_distributions, dict(shape=(32, 32), ns=[2, 0, 2.0]), ValueError, r"'ns' lists 2.0 twice"),
        (presets.fractal_grid, dict(cell=32, alphas=(2.0, 1.5, 2.0)), ValueError, r"'alphas' lists 2.0 twice"),
        (presets.fractal_grid, dict(cell=32, betas=(3.0, 3)), ValueError, r"'betas' lists 3 twice"),
        # a float connectivity had been taken for the integer
        (presets.weight_distributions, dict(shape=(16, 16), connectivity=8.0), TypeError, r"'connectivity'.*8.0"),
    ],
)
def test_panel_lists_are_non_empty_sequences_without_repeats(func, kw, exc, match, launches):
    with pytest.raises(exc, match=match):
        func(**kw)
    assert launches == []


MULTI_PANEL = {  # name -> (its small run, the labels it must carry, panel shape, columns)
    "fractal_grid": (lambda: run("fractal_grid"),
                     ["alpha = 2, beta = 2", "alpha = 1.5, beta = 2", "alpha = 2, beta = 3", "alpha = 1.5, beta = 3"],
                     (40, 40), 2),
    "weight_distributions": (lambda: run("weight_distributions"), ["n = 0", "n = 1", "n = 4", "n = 8"], (48, 48), 4),
    "tropisms": (lambda: run("tropisms"),
                 ["(a) toward left, root left", "(b) toward left, root right", "(c) toward right, root left",
                  "(d) toward right, root right", "(e) toward axis, root center", "(f) away from axis, root center",
                  "(g) toward top, root center", "(h) toward bottom, root center"], (48, 48), 4),
    "width_demo": (lambda: run("width_demo"), ["T = 5.0", "T = 1.6", "Ts = 0.6", "Ts = 0.2"], (64, 40), 4),
    "taper_demo": (lambda: run("taper_demo"), ["T = 5", "eq. 2 along each path", "eq. 2 along each branch"],
                   (64, 64), 3),
    "tropism_objects": (lambda: run("tropism_objects"), ["toward axis", "toward top"], (320, 320), 2),
    "power_weights": (lambda: presets.power_weights((48, 48), alphas=(0.5, 2.0), endpoints=6, seed=1),
                      ["alpha = 0.5", "alpha = 2"], (48, 48), 2),
    "cheap_paths": (lambda: presets.cheap_paths((60, 60), factors=(1.0, 0.5, 0.25), added=6, seed=1),
                    ["D = 1", "D = 0.5", "D = 0.25"], (60, 60), 2),
}


@pytest.mark.parametrize("name", sorted(MULTI_PANEL))
def test_every_panel_of_a_figure_is_labelled_with_its_parameters(name):
    make, labels, (h, w), columns = MULTI_PANEL[name]
    res = make()
    assert res.parts["labels"] == labels
    img, rows = res.image, -(-len(labels) // columns)
    assert img.shape[1] == columns * w + (columns - 1) * 4
    strip = (img.shape[0] - (rows - 1) * 4) // rows - h
    assert strip > 0 and img.shape[0] == rows * (h + strip) + (rows - 1) * 4
    strips = []
    for k in range(len(labels)):
        r, c = divmod(k, columns)
        y, x = r * (h + strip + 4), c * (w + 4)
        above = img[y: y + strip, x: x + w]
        ink = np.flatnonzero((above < 0.9).any(axis=(0, 2)))
        assert ink.size, f"panel {k} of {name} has no label"
        assert abs((ink[0] + ink[-1] + 1) / 2 - w / 2) <= 2  # centred over its panel
        strips.append(above)
    assert all(not np.array_equal(a, b) for i, a in enumerate(strips) for b in strips[i + 1:])


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_tropisms_grow_from_the_bottom_row_and_lean_toward_the_cheap_side(seed):
    # thesis Fig. 4.5: the root at the bottom, the same endpoints in every panel, the weights make the difference
    res = presets.tropisms((64, 64), endpoints=12, seed=seed)
    dens = res.parts["dendrites"]
    ends = {tuple(map(tuple, d.nodes[d.endpoints].tolist())) for d in dens.values()}
    assert len(ends) == 1  # (as sets of coordinates: endpoints rows come in each dendrite's own order)
    for (toward, root), den in dens.items():
        (r, c), = den.nodes[den.roots].tolist()
        assert r == 61 and {"left": c < 16, "center": c == 32, "right": c > 48}[root]
    x = {k: d.nodes[:, 1].mean() for k, d in dens.items()}
    y = {k: d.nodes[:, 0].mean() for k, d in dens.items()}
    off_axis = {k: np.abs(d.nodes[:, 1] - 32).mean() for k, d in dens.items()}
    for root in ("left", "right"):
        assert x[("left", root)] < x[("right", root)]
    assert y[("top", "center")] < y[("bottom", "center")]  # rows grow downward: nodes higher up
    assert off_axis[("axis", "center")] < off_axis[("away_from_axis", "center")]


def test_panel_lists_key_every_panel():
    res = presets.weight_distributions((16, 16), ns=np.array([0.5, 2.0]), endpoints=3, seed=1)
    assert list(res.parts["dendrites"]) == [0.5, 2.0]


def test_costs_refuse_more_generators_than_nodes_before_any_kernel(launches):
    from wdendrite import _models

    with pytest.raises(ValueError, match=r"'generators' <= 64 \(the node count of the 8 x 8 lattice\), but got 1000"):
        _models.costs(8, generators=1000)
    assert launches == []


def test_costs_with_every_node_a_generator_make_a_flat_picture(monkeypatch):
    import warnings

    from wdendrite import _checks, _models

    class EveryNode:
        def integers(self, low, high, size):
            return np.indices((8, 8)).reshape(2, -1).T

    monkeypatch.setattr(_checks, "rng", lambda seed: EveryNode())
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # (a division by 0 had warned and made NaN bands)
        made = _models.costs(8, generators=64)
    assert np.all(made.parts["field"] == 0)
    assert np.isfinite(made.image).all() and np.all(made.image[..., 1] == made.image[0, 0, 1])


def test_the_fractal_command_refuses_a_d_beyond_every_path_cost(launches):
    from wdendrite import _models

    with pytest.raises(ValueError, match=r"^Expected 'd' <= \S+ on a 32 x 32 lattice .*but got 1e\+30$"):
        _models.fractal(32, d=1e30)
    assert launches == []


def test_the_fractal_command_checks_its_schedule_before_the_lattice(launches):
    from wdendrite import _models

    with pytest.raises(ValueError, match="cheap"):
        _models.fractal(32, cheap=2.0)
    assert launches == []


@pytest.mark.parametrize("func, kw, where", [
    (presets.elm_tree, dict(shape=(8, 8, 8), endpoints=500), "in the crown"),
    (presets.staghorn_coral, dict(shape=(12, 12, 12), endpoints=300, refine_n=None), "on the dome"),
    (presets.moss, dict(shape=(12, 12, 12), endpoints=400), "in the band above the plane"),
    (presets.tropism_objects, dict(shape=(10, 10, 10), endpoints=300), "in the upper part"),
    (presets.simple_dendrite, dict(shape=(8, 8), endpoints=100), "in"),
    (presets.weight_distributions, dict(shape=(8, 8), endpoints=100), "in"),
    (presets.tropisms, dict(shape=(8, 8)), "in the upper three quarters"),
    (presets.taper_demo, dict(shape=(8, 8), endpoints=100), "in the lower half"),
])
def test_too_many_endpoints_are_reported_against_the_presets_own_parameter(func, kw, where):
    count = kw.get("endpoints", 20)
    with pytest.raises(ValueError, match=rf"^'endpoints' = {count} is more than fit {where} (of )?the "):
        func(**kw)
    # other errors keep their own words
    with pytest.raises(ValueError, match=r"^Expected .*'seed'"):
        func(**kw, seed=-1)


@pytest.mark.parametrize("kw, match", [
    (dict(alpha=1e308), r"'alpha' = 1e\+308 over 'iterations' = 4 shrinks"),
    (dict(iterations=10**12), r"'alpha' = 2.0 over 'iterations' = 1000000000000 shrinks"),
    (dict(alpha=0.0), r"'alpha'"),
])
def test_fractal_schedules_that_overflow_are_refused_by_name(kw, match, launches):
    with pytest.raises(ValueError, match=match):
        presets.dla_imitation((32, 32), **kw)
    assert launches == []


@pytest.mark.parametrize("text", [b"A", None, ["A"], 7])
def test_letters_take_text_only(text, launches):
    with pytest.raises(TypeError, match="Expected a str for 'text'"):  # (str() of it had been drawn)
        presets.letters(text, height=32)
    assert launches == []
    if text is None:  # with a mask, the text is not drawn at all
        mask = np.zeros((40, 40), bool)
        mask[10:30, 15:25] = True
        assert presets.letters(text, mask=mask, seed=0).dendrite.nodes.shape[1] == 2


def test_letters_take_any_density_and_refuse_a_height_pillow_cannot_draw():
    den = presets.letters("I", height=20, paths_per_1000=1e308).dendrite
    assert len(den.endpoints) == int(presets.letters("I", height=20).parts["mask"].sum())  # every node
    with pytest.raises(ValueError, match=r"'height' = 100000 is too large for Pillow"):
        presets.letters("Hello", height=100000)


def test_moss_scales_its_default_endpoints_with_the_volume():
    import inspect

    assert inspect.signature(presets.moss).parameters["endpoints"].default is None
    den = presets.moss((12, 16, 16)).dendrite  # 800 at 40 x 96 x 96 would not fit here
    assert len(den.endpoints) == round(800 * 12 * 16 * 16 / (40 * 96 * 96))


@pytest.mark.parametrize("seed", range(4))
def test_a_rock_stays_clear_of_the_lattice_walls(seed):
    # its neighbours surround it evenly, so the central region closes before the walls
    label = presets.rock((32, 32, 32), seed=seed).parts["costfield"].label
    inside = label == 0
    walls = [inside[0], inside[-1], inside[:, 0], inside[:, -1], inside[:, :, 0], inside[:, :, -1]]
    assert inside.sum() > 0.02 * inside.size and not any(w.any() for w in walls)


def test_tree_spheres_and_isosurfaces_hold_together():
    spheres = presets.elm_tree((32, 32, 32), endpoints=6, geometry="spheres")
    den = spheres.dendrite
    r = np.linalg.norm(spheres.mesh.vertices.reshape(len(den), -1, 3)
                       - den.positions[:, None, ::-1], axis=2).max(axis=1)
    step = np.linalg.norm(den.positions[den.parent[den.parent >= 0]] - den.positions[den.parent >= 0], axis=1)
    # every sphere reaches at least halfway to its parent: the tree is a chain of touching beads
    assert np.all(r[den.parent >= 0] + r[den.parent[den.parent >= 0]] >= step - 1e-6)
    assert r.min() == pytest.approx(0.5 * 3**0.5, rel=1e-3)  # the twigs' taper alone is thinner at 32^3
    iso = presets.elm_tree((32, 32, 32), endpoints=6, geometry="isosurface").mesh
    assert len(iso.split(only_watertight=False)) == 1


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_fractal_presets_grow_inside_their_lattice(seed):
    # the first cost d comes from the lattice's measured path cost per node, so the tips stop
    # short of the border (with the mean weight instead they ran off every side)
    for den, side in [(presets.dla_imitation((96, 96), seed=seed).dendrite, 96),
                      (presets.competition((96, 96), seed=seed).dendrite, 96),
                      *[(d, 48) for d in presets.fractal_grid(48, seed=seed).parts["dendrites"].values()]]:
        assert not ((den.nodes == 0) | (den.nodes == side - 1)).any(), (seed, side)
        # and they still fill most of it: each generator's tips reach past half its room
        for k, root in enumerate(den.nodes[den.parent < 0]):
            room = side / 3 if den.label.max() > 0 else side / 2  # competition: generators at 1/3 and 2/3
            reach = np.sqrt(((den.nodes[den.label == k] - root) ** 2).sum(1)).max()
            assert reach > 0.5 * room, (seed, side, k, reach)


def test_weight_n0_on_the_thesis_lattice_gives_manhattan_paths():
    # 4-connected and every weight equal: each path is a staircase as long as its Manhattan distance
    res = presets.weight_distributions((48, 48), ns=(0,), endpoints=6, seed=3)
    den = res.parts["dendrites"][0]
    root = den.nodes[den.parent < 0][0]
    for e in den.endpoints:
        path = den.path(int(e))
        assert len(path) - 1 == np.abs(den.nodes[e] - root).sum()
    assert (np.abs(den.nodes[den.parent >= 0] - den.nodes[den.parent[den.parent >= 0]]).sum(1) == 1).all()
    with pytest.raises(ValueError, match="'connectivity' 4 or 8"):
        presets.weight_distributions((48, 48), connectivity=6)


def test_simple_dendrite_endpoints_keep_apart():
    den = presets.simple_dendrite((96, 96), endpoints=12, seed=2).dendrite
    ends = den.nodes[den.endpoints]
    gaps = np.sqrt(((ends[:, None] - ends[None]) ** 2).sum(-1))[np.triu_indices(len(ends), 1)]
    assert gaps.min() >= 96 / 12


def test_lightning_falls_off_with_path_cost_by_default_and_with_pixels_on_request():
    # the same strokes; by default the brightness is the papers' exp(-(c/T)^2) of a path cost, so it
    # differs off the strokes from the Euclidean one, and both are 1 on the main channel
    kw = dict(forks=3, minor_forks=2)
    a = presets.lightning((96, 96), params=LightningParams(metric="euclidean", **kw), seed=2)
    b = presets.lightning((96, 96), params=LightningParams(**kw), seed=2)
    np.testing.assert_array_equal(a.dendrite.nodes, b.dendrite.nodes)
    va, vb = a.parts["value"], b.parts["value"]
    assert 0.0 <= vb.min() and vb.max() <= 1.0 and not np.allclose(va, vb)
    on = tuple(b.parts["main"].nodes.T)
    assert (va[on] == 1.0).all() and (vb[on] == 1.0).all()
    with pytest.raises(ValueError, match="'metric'"):
        LightningParams(metric="manhattan")
