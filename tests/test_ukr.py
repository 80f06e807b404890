"""The continuous and the linear grasp manifold (`manifold.ukr`, `manifold.linear`) and the representations by name."""

import numpy as np
import pytest

import graspmanifold as gm
from graspmanifold.manifold.embeddings import isomap, pca_embedding, principal_axes
from graspmanifold.manifold.linear import LinearManifold
from graspmanifold.manifold.representations import REPRESENTATIONS, fit_representation, load_representation
from graspmanifold.manifold.ukr import UKR, complete_reference, loo_error, loo_error_reference
from graspmanifold.sim.posture import pcp_mask


def sheet(n: int, seed: int = 0) -> np.ndarray:
    """Postures on a bent 2-d sheet in the 22-joint space (rad): a known smooth manifold."""
    u = np.random.default_rng(seed).uniform(0, 1, (n, 2))
    basis = np.random.default_rng(99).normal(0, 0.4, (4, 22))
    return 0.6 + np.column_stack([u, np.sin(2.5 * u[:, :1]), u[:, 1:] ** 2]) @ basis


@pytest.fixture(scope="module")
def fitted() -> tuple[UKR, np.ndarray]:
    postures = sheet(160)
    return UKR(2, iterations=60).fit(postures, progress=False), postures


def test_the_fit_lowers_the_leave_one_out_error_below_its_start(fitted):
    ukr, postures = fitted
    record = ukr.history[0]
    assert record["start"] in ("pca", "isomap") and record["postures"] == len(postures)
    assert record["loo"] < 0.5 * record["loo_start"]
    assert ukr.loo_error() == pytest.approx(record["loo"], rel=1e-9)
    assert ukr.latent.shape == (160, 2) and ukr.references.shape == (160, 22)


def test_the_compiled_error_and_gradient_equal_the_numpy_reference_and_finite_differences(rng):
    for scale in (0.3, 3.0, 30.0):
        latent, postures = rng.normal(0, scale, (50, 2)), rng.normal(0, 1, (50, 22))
        error, gradient = loo_error(latent, postures, gradient=True)
        reference, reference_gradient = loo_error_reference(latent, postures, gradient=True)
        assert error == pytest.approx(reference, rel=1e-10)
        np.testing.assert_allclose(gradient, reference_gradient, rtol=1e-8, atol=1e-12)
    latent = rng.normal(0, 2.0, (20, 2))
    postures = rng.normal(0, 1, (20, 22))
    _, gradient = loo_error_reference(latent, postures, gradient=True)
    step, numeric = 1e-6, np.zeros_like(latent)
    for index in np.ndindex(latent.shape):
        plus, minus = latent.copy(), latent.copy()
        plus[index] += step
        minus[index] -= step
        numeric[index] = (loo_error_reference(plus, postures) - loo_error_reference(minus, postures)) / (2 * step)
    np.testing.assert_allclose(gradient, numeric, atol=1e-7)


def test_a_training_posture_is_completed_from_half_its_joints(fitted):
    ukr, postures = fitted
    mask = pcp_mask(["ffdistal", "mfmiddle", "thdistal"])  # touch: two fingers' joints and the thumb's
    assert 0.4 < mask.mean() < 0.7
    completed = ukr.complete_batch(postures[:40], mask)
    hidden = np.degrees(np.sqrt(((completed - postures[:40])[:, ~mask] ** 2).mean()))
    assert hidden < 3.0, f"RMS error {hidden:.2f} deg over the hidden joints"  # the joints span ~40 deg
    # a completion fits the specified joints at least as well as the best match it starts from
    starts = ukr.references[ukr.best_match_batch(postures[:40], mask)]
    fit = ((completed - postures[:40])[:, mask] ** 2).sum(axis=1)
    assert np.all(fit <= ((starts - postures[:40])[:, mask] ** 2).sum(axis=1) + 1e-15)


def test_masked_completion_never_reads_a_masked_joint(fitted, engine):
    ukr, postures = fitted
    mask = pcp_mask(["ffproximal", "thmiddle", "lfdistal"])
    clean = ukr.complete(np.where(mask, postures[3], np.nan), mask)
    for poison in (1e6, -1e6, np.inf):
        np.testing.assert_array_equal(ukr.complete(np.where(mask, postures[3], poison), mask), clean)
    weights = mask * 2.0
    np.testing.assert_array_equal(ukr.complete_batch(np.where(mask, postures[:5], 1e9), weights),
                                  ukr.complete_batch(np.where(mask, postures[:5], np.nan), weights))


def test_compiled_completion_equals_the_numpy_reference(fitted, rng):
    ukr, postures = fitted
    queries = postures[:30] + rng.normal(0, 0.02, (30, 22))
    masks = rng.random((30, 22)) < 0.5
    masks[:, 0] = True
    latent, completed = ukr.complete_latent_batch(queries, masks)
    checked = np.where(masks, queries, 0.0)
    ref_latent, ref_completed = complete_reference(ukr.latent, ukr.postures, checked, masks.astype(float),
                                                   ukr.best_match_batch(queries, masks), ukr.completion_steps)
    np.testing.assert_allclose(latent, ref_latent, atol=1e-6)
    np.testing.assert_allclose(completed, ref_completed, atol=1e-6)
    np.testing.assert_allclose(ukr.manifold(latent), completed, atol=1e-9)


def test_save_load_round_trip_and_resume(fitted, tmp_path):
    ukr, postures = fitted
    path = ukr.save(tmp_path / "ukr.npz")
    again = load_representation(path)
    assert isinstance(again, UKR) and again.history == ukr.history
    np.testing.assert_array_equal(again.latent, ukr.latent)
    mask = pcp_mask(["ffdistal", "thdistal"])
    np.testing.assert_array_equal(again.complete_batch(postures[:10], mask), ukr.complete_batch(postures[:10], mask))
    more = sheet(40, seed=1)
    before = __import__("copy").copy(again)
    again.resume(more, iterations=10)
    assert len(before.history) == 1 and len(before.postures) == 160  # a shallow copy keeps what it had
    assert len(again.postures) == 200 and again.history[-1]["kind"] == "resume"
    assert again.history[-1]["loo"] <= again.history[-1]["loo_start"]


@pytest.mark.parametrize("call, message", [
    (lambda u, y: UKR(0), "latent_dim must be"),
    (lambda u, y: UKR(4), "latent_dim must be"),
    (lambda u, y: UKR(starts=("lle",)), "starts must be one of"),
    (lambda u, y: UKR().fit(np.where(np.arange(22) == 3, np.nan, y)), "non-finite"),
    (lambda u, y: UKR().fit(y[:3]), "more than latent_dim"),
    (lambda u, y: UKR().complete(y[0]), "not fitted"),
    (lambda u, y: u.complete(y[0][:20]), "x must have shape"),
    (lambda u, y: u.complete(y[0], np.zeros(22)), "selects no dimension"),
    (lambda u, y: u.complete(np.full(22, np.nan), np.ones(22)), "non-finite"),
    (lambda u, y: u.complete_batch(y[:4], np.ones((3, 22))), "mask must have shape"),
    (lambda u, y: u.manifold(np.zeros(3)), "latent must be"),
    (lambda u, y: LinearManifold(0), "components must be"),
    (lambda u, y: LinearManifold(30).fit(y), "at most min"),
    (lambda u, y: fit_representation("kohonen", y), "representation must be one of"),
])
def test_bad_input_gets_a_clear_error(fitted, call, message):
    ukr, postures = fitted
    with pytest.raises(gm.GraspManifoldError, match=message):
        call(ukr, postures)


def test_the_linear_manifold_completes_in_closed_form(rng, tmp_path):
    postures = sheet(120)
    linear = LinearManifold(3).fit(postures)
    assert linear.explained.sum() == pytest.approx(1.0) and linear.explained[:4].sum() > 0.999  # a 4-d sheet
    assert linear.components_for(linear.explained[:2].sum()) == 2
    mask = pcp_mask(["ffdistal", "thdistal"])
    x = postures[5]
    given = linear.axes[:, mask]  # the conditional mean of probabilistic PCA, written out
    latent = np.linalg.solve(given @ given.T + linear.residual * np.diag(1 / linear.variances),
                             given @ (x - linear.mean)[mask])
    np.testing.assert_allclose(linear.complete(np.where(mask, x, np.nan), mask), linear.mean + latent @ linear.axes,
                               atol=1e-9)
    few = np.zeros(22, bool)
    few[0] = True  # fewer specified joints than components: the prior keeps the posture near the data
    assert np.abs(linear.complete(x, few) - linear.mean).max() < np.abs(postures - linear.mean).max()
    np.testing.assert_allclose(linear.complete(x), linear.project(x[None])[0], atol=1e-3)  # shrinkage only
    again = load_representation(linear.save(tmp_path / "linear.npz"))
    np.testing.assert_array_equal(again.complete_batch(postures[:9], mask), linear.complete_batch(postures[:9], mask))


def test_the_embeddings_recover_a_sheet_and_fix_their_signs(rng):
    postures = sheet(100)
    mean, axes, explained = principal_axes(postures)
    np.testing.assert_allclose(axes @ axes.T, np.eye(len(axes)), atol=1e-10)
    assert np.all(axes[np.arange(len(axes)), np.abs(axes).argmax(axis=1)] > 0)
    np.testing.assert_allclose(pca_embedding(postures, 2), (postures - mean) @ axes[:2].T)
    coordinates = isomap(postures, 2)
    assert coordinates.shape == (100, 2) and np.all(np.isfinite(coordinates))
    two_clusters = np.vstack([postures, postures + 5.0])  # far apart: the spanning tree still joins the graph
    assert np.all(np.isfinite(isomap(two_clusters, 2)))


def test_every_representation_is_made_by_name_and_recalled_in_a_trial(tmp_path):
    postures = sheet(60)
    for name in REPRESENTATIONS:
        experience = fit_representation(name, postures, progress=False)
        assert isinstance(experience, gm.Experience) and experience.dim == 22
    grasps = gm.PostureSet.load("tests/data/v0_1/postures.npz").postures[:60]  # the sheet lies beyond the hand's ranges
    ukr = fit_representation("ukr", grasps, progress=False)
    result = gm.evaluate("cylinder", ukr, np.array([[0.0, 0.0, 0.01, 0.0]]), workers=1, progress=False, method="ukr")
    assert result.summary["trials"] == 1 and result.method == "ukr"


def test_touch_masks_hide_each_finger_from_its_tip_and_random_masks_anywhere():
    from graspmanifold.studies.completion import masks

    for level, hidden in ((0.25, 6), (0.5, 11), (0.75, 16)):
        touch = masks("touch", level, 200, seed=0)
        assert np.all((~touch).sum(axis=1) == hidden)
        for chain in (slice(0, 4), slice(4, 8), slice(8, 12), slice(12, 17), slice(17, 22)):  # base to tip
            given = touch[:, chain].astype(int)
            assert np.all(np.diff(given, axis=1) <= 0), "a specified joint beyond a hidden one of its finger"
        assert np.all((~masks("random", level, 50, seed=0)).sum(axis=1) == hidden)
    np.testing.assert_array_equal(masks("touch", 0.5, 10, seed=3), masks("touch", 0.5, 10, seed=3))
    with pytest.raises(gm.InvalidInput, match="scheme must be one of"):
        masks("touch", 1.0, 3, seed=0)


def test_the_completion_study_runs_on_posture_files(tmp_path):
    from graspmanifold.studies.completion import main

    for seed in (0, 1):
        for k, name in enumerate(("box", "pen")):
            postures = sheet(70, seed=10 * seed + k)
            gm.PostureSet(postures=postures, hand_poses=np.tile([0, 0, 0.1, 1, 0, 0, 0.0], (70, 1)),
                          start_ids=np.zeros(70, int), contacts=np.ones((70, len(gm.SEGMENTS)), bool),
                          epsilon=np.zeros(70), hold_displacement=np.zeros(70), start_names=("s",),
                          metadata={}).save(tmp_path / f"experience_{name}{f'_seed{seed}' if seed else ''}.npz")
    doc = tmp_path / "report.md"
    main(["--quick", "--no-trials", "--postures", str(tmp_path), "--out", str(tmp_path / "out"), "--doc", str(doc)])
    text = doc.read_text()
    assert "| ukr2 - som | touch/0.50 | 280 |" in text and "| ukr2 - database |" in text and "components for 90 %" in text
    assert (tmp_path / "report_errors.png").exists() and "Target" in text
    info = __import__("json").loads((tmp_path / "out" / "study.json").read_text())
    rows = {(r["representation"], r["condition"]): r for r in info["completion"]["rows"]}
    assert rows[("ukr2", "touch/0.25")]["deg_mean"] < rows[("pca2", "touch/0.25")]["deg_mean"]  # a bent sheet
