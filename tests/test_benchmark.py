"""The benchmark where grasp choice matters: its grids, and that the controller never learns the object."""

import dataclasses
import inspect

import numpy as np
import pytest

import graspmanifold as gm
from graspmanifold.control.controller import BatchController
from graspmanifold.sim.objects import GraspObject
from graspmanifold.trials import setup as trial_setup
from graspmanifold.trials.benchmark import (OBJECTS, PLACEMENTS, benchmark_grid, cells, compare_pooled, pooled,
                                            run_benchmark)


def test_the_test_and_selection_grids_share_no_value_and_hold_enough_poses():
    total = 0
    for name, placement in cells():
        test, selection = benchmark_grid(name, placement), benchmark_grid(name, placement, "selection")
        assert len(test) >= 30 and len(selection) >= 10
        for axis in range(3):  # x, z and gap never coincide; a ball's yaw is always 0
            assert not set(np.round(test[:, axis], 6)) & set(np.round(selection[:, axis], 6)), (name, placement, axis)
        assert gm.reachable(OBJECTS[name].object, test).all()
        total += len(test)
    assert total >= 600
    with pytest.raises(ValueError, match="placement must be one of"):
        benchmark_grid("marble", "shelf")
    with pytest.raises(ValueError, match="unknown benchmark object"):
        benchmark_grid("teapot", "palm")


def test_small_objects_sit_at_the_fingertips_further_out_than_at_the_palm():
    for name in OBJECTS:
        palm, tips = (benchmark_grid(name, p) for p in PLACEMENTS)
        assert tips[:, 1].min() > palm[:, 1].max()  # further along the fingers
    assert {b.grasp for b in OBJECTS.values()} >= {"power", "precision", "tripod", "lateral"}


def test_the_controller_is_never_told_the_object(monkeypatch):
    """Neither the controller's constructors nor anything evaluate hands them name the object: they get
    an experience, parameters and postures, then joint angles and segment forces every cycle."""
    for cls in (gm.GraspController, BatchController):
        names = set(inspect.signature(cls.__init__).parameters) - {"self"}
        assert names <= {"n", "experience", "params", "initial_posture", "preshape", "hand", "regrasp", "recall"}, (cls, names)
    seen = []

    class Spy(BatchController):
        def __init__(self, *args, **kwargs):
            seen.extend([*args, *kwargs.values()])
            super().__init__(*args, **kwargs)

        def step(self, joints, segment_forces):
            seen.extend([joints, segment_forces])
            return super().step(joints, segment_forces)

    monkeypatch.setattr(trial_setup, "BatchController", Spy)
    database = gm.PostureDatabase(np.tile(gm.closed_posture() * 0.5, (3, 1)))
    results = run_benchmark(database, objects=("marble",), every=27)
    assert sum(len(r.trials) for r in results.values()) >= 2 and seen
    for value in seen:
        assert not isinstance(value, (GraspObject, gm.Scene, str)), type(value)
        if isinstance(value, np.ndarray):
            assert value.dtype.kind in "fb" and value.shape[-1] in (len(gm.FINGER_JOINTS), len(gm.SEGMENTS))


def test_a_benchmark_run_is_kept_and_taken_up_again(tmp_path, monkeypatch):
    first = run_benchmark(None, objects=("pen",), every=25, store=tmp_path, method="none")
    assert sorted(p.name for p in tmp_path.glob("*.npz")) == ["none_test_pen_fingertips.npz", "none_test_pen_palm.npz"]

    def no_trials(*args, **kwargs):
        raise AssertionError("a stored cell ran again")

    monkeypatch.setattr(gm.benchmark, "evaluate", no_trials)
    again = run_benchmark(None, objects=("pen",), every=25, store=tmp_path, method="none")
    for key in first:
        assert np.array_equal(first[key].outcomes(), again[key].outcomes())
    outcomes, valid = pooled(again)
    assert len(outcomes) == len(valid) == sum(len(r.trials) for r in again.values())
    with pytest.raises(ValueError, match="none of the cells"):
        pooled(again, rows=[("marble", "palm")])
    ran = []
    monkeypatch.setattr(gm.benchmark, "evaluate", lambda *args, **kwargs: ran.append(kwargs["seed"]) or first[
        ("pen", "palm")])
    run_benchmark(None, objects=("pen",), every=25, store=tmp_path, method="none", seed=1)
    assert ran == [1, 1]  # another seed under the same label is run, not taken from the store
    for bad, message in ((dict(objects=("teapot",)), "benchmark objects"), (dict(split="train"), "split"),
                         (dict(every=0), "every")):
        with pytest.raises(ValueError, match=message):
            run_benchmark(None, **bad)


def test_a_comparison_leaves_out_a_failed_physics_or_counts_it_as_a_failed_grasp():
    grid = benchmark_grid("pen", "palm")[::25]
    held = gm.evaluate(OBJECTS["pen"].object, None, grid, workers=1, progress=False)
    faulted = dataclasses.replace(held, trials=[dataclasses.replace(held.trials[0], hold=True, fault="deep contact"),
                                               *held.trials[1:]])
    a, b = {("pen", "palm"): faulted}, {("pen", "palm"): held}
    dropped, counted = compare_pooled(a, b), compare_pooled(a, b, invalid="fail")
    assert dropped.n == len(grid) - 1 and counted.n == len(grid)
    assert counted.only_b == dropped.only_b + int(held.trials[0].hold) and counted.only_a == dropped.only_a
    with pytest.raises(ValueError, match="invalid must be one of"):
        compare_pooled(a, b, invalid="keep")
    first = np.zeros(len(grid), dtype=bool)
    first[0] = True  # only the faulted pose: nothing left to pair once it is dropped
    assert compare_pooled(a, b, keep={("pen", "palm"): first}).n == 0
    assert compare_pooled(a, b, keep={("pen", "palm"): ~first}).n == dropped.n
    assert len(pooled(a, keep={("pen", "palm"): ~first})[0]) == len(grid) - 1
    with pytest.raises(ValueError, match=r"keep must give the cell \('pen', 'palm'\) one bool per trial"):
        pooled(a, keep={("pen", "palm"): first[1:]})
