"""The SOM: exact masked best match, determinism, training quality, structure, files, bad input."""

import numpy as np
import pytest

import graspmanifold as gm
from graspmanifold.manifold.som import SOM, decay_schedule


def clustered_postures(rng, n=600, clusters=5, dim=22, spread=0.05):
    """Posture-like data: tight clusters around random postures inside the joint limits."""
    limits = gm.finger_limits()[:dim] if dim <= 22 else np.tile([0.0, 1.5], (dim, 1))
    centres = rng.uniform(limits[:, 0], limits[:, 1], (clusters, dim))
    return centres[rng.integers(0, clusters, n)] + rng.normal(0.0, spread, (n, dim))


def brute_force(weights, x, mask):
    return int(np.argmin(np.sum(mask * (weights - x) ** 2, axis=1)))


@pytest.fixture(scope="module")
def trained():
    rng = np.random.default_rng(7)
    data = clustered_postures(rng)
    return gm.SOM(8, 9, 22, seed=1).fit(data, epochs=8), data


def test_best_match_agrees_with_brute_force_for_random_maps_queries_and_masks(rng, engine):
    for trial in range(40):
        rows, cols, dim = rng.integers(1, 9), rng.integers(1, 9), rng.integers(1, 30)
        som = gm.SOM(rows, cols, dim, seed=trial)
        som.weights = rng.normal(size=(rows, cols, dim)) * rng.uniform(0.01, 10)
        flat = som.weights.reshape(-1, dim)
        queries = rng.normal(size=(50, dim)) * rng.uniform(0.01, 10)
        boolean = rng.random((50, dim)) < 0.4
        boolean[~boolean.any(axis=1), 0] = True
        weighted = rng.random((50, dim)) * (rng.random((50, dim)) < 0.7)
        weighted[~(weighted > 0).any(axis=1), -1] = 0.5
        for masks in (boolean, weighted, np.ones((50, dim))):
            expected = [brute_force(flat, q, m) for q, m in zip(queries, masks)]
            assert [som.best_match(q, m) for q, m in zip(queries, masks)] == expected
            assert som.best_match_batch(queries, masks).tolist() == expected
            for q, m, e in zip(queries[:5], masks[:5], expected[:5]):
                np.testing.assert_array_equal(som.complete(q, m), flat[e])
        # one mask for all queries, and no mask at all
        assert som.best_match_batch(queries, boolean[0]).tolist() == [brute_force(flat, q, boolean[0]) for q in queries]
        assert som.best_match_batch(queries).tolist() == [brute_force(flat, q, 1.0) for q in queries]


def test_exact_ties_resolve_to_the_lowest_index(engine):
    som = gm.SOM(2, 2, 3)
    som.weights = np.array([[[0, 0, 0], [1, 0, 5]], [[1, 0, -5], [0, 0, 9]]], dtype=float)
    # with only the first two dimensions active, nodes 1 and 2 are both at distance 0 from (1, 0)
    assert som.best_match([1, 0, 100], [1, 1, 0]) == 1
    assert som.best_match_batch([[1, 0, 100]], [[True, True, False]]).tolist() == [1]


def test_unspecified_dimensions_may_be_nan(trained, engine):
    som, data = trained
    mask = gm.pcp_mask(["ffdistal", "thmiddle"])
    pcp = np.where(mask, data[3], np.nan)
    assert som.best_match(pcp, mask) == som.best_match(np.where(mask, data[3], 0.0), mask)
    with pytest.raises(ValueError, match="non-finite"):
        som.best_match(pcp, np.ones(22))


def test_same_seed_gives_identical_weights_bit_for_bit(rng, engine):
    data = clustered_postures(rng, n=300)
    for algorithm in ("online", "batch"):
        a = gm.SOM(6, 7, 22, seed=11).fit(data, epochs=4, algorithm=algorithm)
        b = gm.SOM(6, 7, 22, seed=11).fit(data, epochs=4, algorithm=algorithm)
        assert a.weights.tobytes() == b.weights.tobytes()
    # the seed drives the online presentation order, so another seed gives another map
    other_seed = gm.SOM(6, 7, 22, seed=12).fit(data, epochs=4)
    assert other_seed.weights.tobytes() != gm.SOM(6, 7, 22, seed=11).fit(data, epochs=4).weights.tobytes()


def textbook_online(initial, data, epochs, learning_rate, sigma, seed, fit_index=0):
    """A plain per-sample SOM loop: w <- w + h (x - w) over the same schedule and order."""
    rows, cols, dim = initial.shape
    w = initial.reshape(-1, dim).copy()
    grid = np.indices((rows, cols)).reshape(2, -1).T
    order_rng = np.random.default_rng([seed, fit_index])
    for rate, s in zip(decay_schedule(*learning_rate, epochs), decay_schedule(*sigma, epochs)):
        for i in order_rng.permutation(len(data)):
            x = data[i]
            best = np.argmin(np.sum((w - x) ** 2, axis=1))
            h = rate * np.exp(-np.sum((grid - grid[best]) ** 2, axis=1) / (2 * s * s))
            h[h < 1e-12 * rate] = 0.0
            w += h[:, None] * (x - w)
    return w.reshape(rows, cols, dim)


def test_online_training_equals_the_textbook_update_and_is_no_worse(rng, engine):
    data = clustered_postures(rng, n=400, clusters=6)
    som = gm.SOM(7, 8, 22, seed=5).initialize(data)
    reference = gm.SOM(7, 8, 22, seed=5)
    reference.weights = textbook_online(som.weights, data, 6, (0.95, 0.05), (4.0, 0.7), seed=5)
    som.fit(data, epochs=6, sigma=(4.0, 0.7))
    np.testing.assert_allclose(som.weights, reference.weights, atol=1e-9)
    assert som.quantization_error(data) <= reference.quantization_error(data) + 1e-9


def test_compiled_best_match_equals_the_numpy_reference_on_large_batches(rng):
    from graspmanifold.base import compiled as switch
    from graspmanifold.manifold.nearest import _PER_THREAD

    data = clustered_postures(rng, n=500, clusters=6)
    # a batch large enough to be split across threads
    queries = data[rng.integers(0, len(data), 3 * _PER_THREAD)] + rng.normal(0, 0.05, (3 * _PER_THREAD, 22))
    masks = rng.random((len(queries), 22)) < 0.3
    masks[:, 5] = True
    som, winners = gm.SOM(9, 11, 22, seed=2).fit(data, epochs=5), {}
    for compiled in (True, False):
        previous = switch.use_compiled(compiled)
        try:
            winners[compiled] = som.best_match_batch(queries, masks)
        finally:
            switch.use_compiled(previous)
    np.testing.assert_array_equal(winners[True], winners[False])
    assert len(np.unique(winners[True])) > 20  # the queries spread over the map


def test_resume_continues_from_the_trained_weights_and_fit_starts_afresh(rng):
    data = clustered_postures(rng, n=300)
    som = gm.SOM(6, 6, 22, seed=2).fit(data, epochs=5)
    before = som.weights.copy()
    more = clustered_postures(rng, n=100)
    som.resume(more, epochs=2, learning_rate=(0.1, 0.05), sigma=(3.0, 0.7))
    assert len(som.history) == 2
    expected = textbook_online(before, more, 2, (0.1, 0.05), (3.0, 0.7), seed=2, fit_index=1)
    np.testing.assert_allclose(som.weights, expected, atol=1e-9)
    som.fit(data, epochs=1)  # fit always starts afresh, as in scikit-learn
    assert len(som.history) == 1
    np.testing.assert_array_equal(som.weights, gm.SOM(6, 6, 22, seed=2).fit(data, epochs=1).weights)
    with pytest.raises(RuntimeError, match="fit"):
        gm.SOM(6, 6, 22).resume(more)


def test_batch_training_orders_the_map_and_fits_the_data(rng):
    data = clustered_postures(rng, n=500, clusters=4)
    online = gm.SOM(10, 10, 22, seed=0).fit(data, epochs=20)
    batch = gm.SOM(10, 10, 22, seed=0).fit(data, epochs=20, algorithm="batch")
    initial = gm.SOM(10, 10, 22, seed=0).initialize(data)
    assert batch.quantization_error(data) < 0.5 * initial.quantization_error(data)
    assert batch.quantization_error(data) < 1.5 * online.quantization_error(data)


def test_quality_and_structure_measures(trained):
    som, data = trained
    qe = som.quantization_error(data)
    flat = som.weights.reshape(-1, 22)
    expected = np.mean([np.linalg.norm(x - flat[brute_force(flat, x, 1.0)]) for x in data])
    assert qe == pytest.approx(expected)
    assert 0.0 <= som.topographic_error(data) <= 1.0
    hits = som.hit_counts(data)
    assert hits.shape == (8, 9) and hits.sum() == len(data)
    np.testing.assert_array_equal(som.unsupported_nodes(data), np.flatnonzero(hits.ravel() == 0))
    horizontal, vertical = som.internode_distances()
    assert horizontal.shape == (8, 8) and vertical.shape == (7, 9)
    assert horizontal[2, 3] == pytest.approx(np.linalg.norm(som.weights[2, 4] - som.weights[2, 3]))
    stats, degrees = som.distance_stats(), som.distance_stats(degrees=True)
    assert degrees["max"] == pytest.approx(np.degrees(stats["max"]))
    assert stats["min"] <= stats["mean"] <= stats["max"] and stats["cv"] == pytest.approx(stats["std"] / stats["mean"])
    assert stats["edges"] == 8 * 8 + 7 * 9


def test_topographic_error_counts_non_neighbouring_winners():
    som = gm.SOM(1, 3, 1)
    som.weights = np.array([[[0.0], [10.0], [1.0]]])
    # 0.4: best node 0, second node 2 (not adjacent); 9.0: best 1, second 2 (adjacent)
    assert som.topographic_error(np.array([[0.4], [9.0]])) == 0.5


def test_save_and_load_round_trip(trained, tmp_path):
    som, data = trained
    path = som.save(tmp_path / "map.npz")
    loaded = gm.SOM.load(path)
    assert loaded.weights.tobytes() == som.weights.tobytes()
    assert (loaded.rows, loaded.cols, loaded.dim, loaded.seed) == (8, 9, 22, 1)
    assert loaded.history == som.history and loaded.history[0]["data_fingerprint"]
    with pytest.raises(FileExistsError):
        som.save(path, overwrite=False)


def test_corrupt_truncated_and_foreign_files_raise_and_overwrite_nothing(trained, tmp_path):
    som, _ = trained
    good = som.save(tmp_path / "map.npz")
    content = good.read_bytes()
    truncated = tmp_path / "truncated.npz"
    truncated.write_bytes(content[: len(content) // 2])
    with pytest.raises(ValueError, match="truncated or corrupt"):
        gm.SOM.load(truncated)
    foreign = tmp_path / "foreign.npz"
    np.savez(foreign, weights=np.zeros((2, 2, 3)))
    with pytest.raises(ValueError, match="no metadata"):
        gm.SOM.load(foreign)
    database = gm.PostureDatabase(np.zeros((3, 22))).save(tmp_path / "db.npz")
    with pytest.raises(ValueError, match="posture_database"):
        gm.SOM.load(database)
    # a failed save leaves the existing file untouched
    with pytest.raises(ValueError):
        som.save(tmp_path / "map.txt")
    assert good.read_bytes() == content


@pytest.mark.parametrize("call, message", [
    (lambda som, X: som.fit(np.vstack([X, [np.nan] * 22])), r"row 600"),
    (lambda som, X: som.fit(np.where(np.arange(22) == 3, np.inf, X[:5])), r"row 0"),
    (lambda som, X: som.fit(X[:, :21]), r"shape \(n, 22\)"),
    (lambda som, X: som.fit(X[:0]), r"n >= 1"),
    (lambda som, X: som.fit(X, epochs=0), "epochs"),
    (lambda som, X: som.fit(X, learning_rate=(1.5, 0.1)), "learning_rate"),
    (lambda som, X: som.fit(X, sigma=(-1, 0.7)), "sigma"),
    (lambda som, X: som.fit(X, algorithm="magic"), "algorithm"),
    (lambda som, X: som.best_match(X[0], np.zeros(22)), "all zero"),
    (lambda som, X: som.best_match(X[0], -np.ones(22)), "negative"),
    (lambda som, X: som.best_match(X[0, :5]), r"shape \(22,\)"),
    (lambda som, X: som.best_match_batch(X[:3], np.ones((2, 22))), "mask must have shape"),
    (lambda som, X: som.best_match_batch(X[:3], np.eye(3, 22) * 0), "all zero"),
    (lambda som, X: som.best_match_batch(X[:3], -np.ones((3, 22))), "negative"),
    (lambda som, X: som.best_match_batch(X[:3], np.full((3, 22), np.inf)), "non-finite weights"),
    (lambda som, X: som.best_match_batch(np.where(np.eye(3, 22), np.nan, X[:3])), "non-finite values"),
    (lambda som, X: som.best_match_batch(X[:3, :5]), "shape"),
])
def test_bad_input_gets_a_clear_error(trained, engine, call, message):
    som, data = trained
    with pytest.raises(ValueError, match=message):
        call(som, data)


def test_constructor_and_untrained_map_errors():
    with pytest.raises(ValueError, match="rows"):
        gm.SOM(0, 5, 3)
    with pytest.raises(ValueError, match="seed"):
        gm.SOM(2, 2, 3, seed=-1)
    with pytest.raises(gm.NotFittedError, match="fit"):
        gm.SOM(2, 2, 3).best_match(np.zeros(3))
    assert not isinstance(gm.SOM(2, 2, 3), gm.Experience)  # the protocol check read the error, not raised it
    assert isinstance(gm.NotFittedError("x"), (gm.GraspManifoldError, RuntimeError))
    som = gm.SOM(2, 2, 3)
    with pytest.raises(ValueError, match="weights must have shape"):
        som.weights = np.zeros((2, 3, 3))


def test_posture_database_matches_brute_force_and_shares_the_interface(rng, engine):
    postures = clustered_postures(rng, n=200)
    database = gm.PostureDatabase(postures)
    som = gm.SOM(3, 3, 22).fit(postures, epochs=1)
    assert isinstance(database, gm.Experience) and isinstance(som, gm.Experience)
    for _ in range(30):
        q = rng.uniform(-0.5, 1.5, 22)
        mask = gm.pcp_mask(rng.choice(gm.SEGMENTS, 3))
        if not mask.any():
            continue
        expected = brute_force(postures, q, mask)
        assert database.best_match(q, mask) == expected
        np.testing.assert_array_equal(database.complete(q, mask), postures[expected])
    with pytest.raises(ValueError, match="non-finite"):
        gm.PostureDatabase(np.full((2, 22), np.nan))


def test_lattice_plots_render_headless(trained, tmp_path):
    import matplotlib

    matplotlib.use("Agg")
    from graspmanifold.manifold.plots import lattice_figure

    som, data = trained
    figure = lattice_figure(som, data, title="test")
    path = tmp_path / "lattice.png"
    figure.savefig(path, dpi=60)
    image = matplotlib.image.imread(path)
    assert image.shape[0] > 100 and image.shape[1] > 200
    assert image[..., :3].std() > 0.05  # not blank: lines, nodes and green hits
    green = (image[..., 1] > 0.7) & (image[..., 0] < 0.5) & (image[..., 2] < 0.5)
    assert green.sum() > 50


def test_the_schedule_lives_in_the_constructor_and_survives_saving(rng, tmp_path):
    data = clustered_postures(rng, n=120)
    som = gm.SOM(5, 5, 22, seed=3, epochs=4, learning_rate=(0.5, 0.1), sigma=(2.0, 0.5), algorithm="batch")
    som.fit(data)
    assert som.history[0]["epochs"] == 4 and som.history[0]["algorithm"] == "batch"
    loaded = gm.SOM.load(som.save(tmp_path / "map.npz"))
    assert (loaded.epochs, loaded.learning_rate, loaded.sigma, loaded.algorithm) == (4, (0.5, 0.1), (2.0, 0.5), "batch")
    with pytest.raises(ValueError, match="epochs"):
        gm.SOM(5, 5, 22, epochs=0)
    with pytest.raises(ValueError, match="algorithm"):
        gm.SOM(5, 5, 22, algorithm="magic")


def test_the_map_takes_its_dimension_from_the_data_and_random_state_names_the_seed(rng):
    """The SOM took `dim` instead of inferring it, and `seed` where scikit-learn users look for `random_state`."""
    data = rng.normal(size=(60, 5))
    inferred = SOM(4, 4, random_state=7).fit(data, epochs=3)
    given = SOM(4, 4, 5, seed=7).fit(data, epochs=3)
    assert inferred.dim == 5 and inferred.seed == 7 and np.array_equal(inferred.weights, given.weights)
    with pytest.raises(ValueError, match="name the same thing"):
        SOM(4, 4, seed=1, random_state=2)
    with pytest.raises(ValueError, match="must be an \\(n, dim\\) array"):
        SOM(4, 4).fit(np.zeros(5))
