"""The goldens the suite pins (tests/data/*.npz) and what of them no last bit moves (issue 50): shared by the tests
that compare with them and by `test_last_bits.py`, which runs them again with their inputs perturbed."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np

import graspmanifold as gm
from graspmanifold.control.controller import BLEND
from graspmanifold.trials.grid import check_grid

DATA = Path(__file__).parent / "data"


def blend_golden_results(perturb: float = 0.0) -> dict[str, gm.EvaluationResult]:
    """The trials of tests/data/blend_trials.npz: `BLEND` recalling from a database and a SOM of the cylinder's
    starts jittered, on every fourth pose of the quick grid, with noise and with its closure restarted; the poses
    changed by `perturb`, relatively, when asked."""
    starts = np.array([s.posture for s in gm.starting_postures("cylinder")])
    rng = np.random.default_rng(0)
    limits = gm.finger_limits()
    postures = np.clip(np.repeat(starts, 10, axis=0) + rng.normal(0, 0.05, (10 * len(starts), 22)),
                       limits[:, 0], limits[:, 1])
    database, som = gm.PostureDatabase(postures), gm.SOM(4, 4, 22, seed=0).fit(postures, epochs=5, progress=False)
    poses = check_grid("quick", gm.get_object("cylinder"))[1][::4]
    poses = poses * (1.0 + perturb * np.random.default_rng(1).standard_normal(poses.shape))
    run = dict(seed=3, workers=1, progress=False, margin=True)
    return {"database": gm.evaluate("cylinder", database, poses, params=BLEND, **run),
            "som_noise": gm.evaluate("cylinder", som, poses, noise=gm.Noise(0.004, 0.08, 0.01), params=BLEND, **run),
            "som_restart": gm.evaluate("cylinder", som, poses, params=replace(BLEND, recall=gm.BlendRecall(restart_closure=True)), **run)}


def assert_matches_golden(result: gm.EvaluationResult, name: str) -> None:
    """What of a blend golden no last bit moves (see the test above): the outcomes, nine in ten winners (trial by
    trial, in order: with the libraries of a fresh install on 2026-12-07 a 1e-12 change of the poses gave one
    database trial two more best matches than the golden, its outcome the same), and the measured values of the
    trials whose recalls all equal the golden's."""
    golden = np.load(DATA / "blend_trials.npz")
    for field in ("touching", "hold", "time_to_grasp", "margin"):
        assert np.array_equal(np.array([getattr(t, field) for t in result.trials]), golden[f"{name}/{field}"]), \
            (name, field)
    golden_winners = np.split(golden[f"{name}/winners"], np.cumsum(golden[f"{name}/matches"])[:-1])
    pairs = [(np.asarray(t.winners), w) for t, w in zip(result.trials, golden_winners)]
    agree = sum(int(np.sum(a[:len(b)] == b[:len(a)])) for a, b in pairs)  # a trial may match once more or less
    assert agree >= 0.9 * sum(len(b) for _, b in pairs), name
    same = [i for i, (a, b) in enumerate(pairs) if np.array_equal(a, b)]
    assert len(same) >= 0.75 * len(result.trials), name
    for field, atol in (("posture", 1e-4), ("epsilon", 1e-4), ("hold_displacement", 1e-3), ("penetration", 1e-5)):
        np.testing.assert_allclose(np.array([getattr(result.trials[i], field) for i in same]),
                                   golden[f"{name}/{field}"][same], rtol=0, atol=atol, err_msg=f"{name} {field}")
