"""The spring-based posture generator, starting postures and posture sets."""

import numpy as np
import pytest

import graspmanifold as gm
from graspmanifold.cli import main as cli
from graspmanifold.synthesis import generator
from graspmanifold.manifold.analysis import nearest_neighbour_deg

SMALL = gm.GeneratorParams(job_size=6, verify=False)  # every five-fingertip candidate, for exact counts


def replay_distances(obj, posture, pose):
    """MuJoCo's own distances from each hand geom to the object, posture replayed in a fresh Scene."""
    scene = gm.Scene(obj)
    scene.set_hand_pose(pose[:3], pose[3:])
    scene.set_posture(posture)
    model = scene.model
    by_segment = {}
    for g in range(model.ngeom):
        body = model.body(model.geom_bodyid[g]).name
        if body in gm.SEGMENTS:
            d = scene.distance_to_object(g, 0.1)
            by_segment[body] = min(d, by_segment.get(body, np.inf))
    return by_segment


def assert_valid_grasp(obj, posture, pose):
    assert gm.within_limits(posture, tol=1e-9)
    distances = replay_distances(obj, posture, pose)
    for segment in gm.DISTAL_SEGMENTS:
        assert distances[segment] <= 0.001, (segment, distances[segment])
    assert min(distances.values()) >= -0.002


@pytest.mark.parametrize("name", ["box", "cylinder", "sphere"])
def test_shipped_starting_postures_are_five_fingertip_grasps(name):
    starts = gm.starting_postures(name)
    assert len(starts) >= 3
    assert len({s.name for s in starts}) == len(starts)
    for start in starts:
        assert_valid_grasp(name, start.posture, np.concatenate([start.hand_pos, start.hand_quat]))
    # distinct grasps: the postures differ clearly
    postures = np.array([s.posture for s in starts])
    gaps = [np.linalg.norm(a - b) for i, a in enumerate(postures) for b in postures[i + 1:]]
    assert min(gaps) > 0.1


@pytest.mark.parametrize("name", ["box", "cylinder", "sphere"])
def test_every_grasp_type_start_is_a_valid_grasp_that_holds(name):
    """The grasp-types family (the default): at least three designs of at least two grasp types, each start a
    valid grasp that holds its object when the verifier replays it (shipped, like the five-fingertip ones)."""
    from graspmanifold.judging.replay import GraspVerifier
    from graspmanifold.synthesis.starts import holds, is_design_grasp

    starts = gm.starting_postures(name, "grasp_types")
    assert gm.GeneratorParams().designs == "grasp_types"
    assert len(starts) >= 3 and len({s.grasp_type for s in starts}) >= 2
    verifier = GraspVerifier(gm.get_object(name))
    for start in starts:
        assert is_design_grasp(name, start) and holds(verifier, start), start.name
    with pytest.raises(ValueError, match="family must be one of"):
        gm.starting_postures(name, "wraps")


@pytest.mark.parametrize("name", ["box", "cylinder", "sphere"])
def test_each_shipped_design_yields_verified_postures_on_its_object(name):
    """Every start of the default family gives verified postures when explored alone: no shipped design is one
    whose candidates never hold (those of the paper's five-fingertip wraps under the squeeze, issue 37)."""
    for start in gm.starting_postures(name, "grasp_types"):
        postures = gm.generate_postures(name, 2, seed=0, workers=1, starts=[start], progress=False,
                                        params=gm.GeneratorParams(job_size=4, max_candidates_per_posture=25))
        assert len(postures) == 2 and postures.metadata["verified_by_start"][start.name] > 0, start.name


def test_the_refinement_terms_make_the_squeeze_press_the_thumb_in_and_the_pushes_cancel():
    """The cause of the paper's wraps that never hold (issue 37): in the cylinder's mid wrap the controller's
    squeeze draws the thumb away from the object (its motion points away from its push). The refinement's press
    term turns it in; its balance term makes the contacts' unit pushes cancel better."""
    from graspmanifold.synthesis.refinement import PRESS_COSINE, StartingPosture, refine
    from graspmanifold.synthesis.start_geometry import SearchGeometry
    from graspmanifold.synthesis.starts import design_pose, design_posture, designs_for

    cylinder = gm.get_object("cylinder")
    design = next(d for d in designs_for(cylinder) if d.name == "wrap_mid")
    pos, quat = design_pose(cylinder, design)
    measured = {}
    for terms in ({}, {"press": 1.0}, {"balance": 2.5}):
        start = refine(cylinder, StartingPosture(design.name, pos, quat, design_posture(design)), **terms)
        geometry = SearchGeometry(gm.Scene(cylinder))
        geometry.distances(start.posture, start.hand_pos, start.hand_quat)
        pushes = geometry.pushes()
        thumb = geometry.pushing.index(geometry.scene.model.geom("thdistal").id)
        measured[tuple(terms)] = (geometry.pressing(start.posture, pushes)[thumb], np.linalg.norm(pushes.mean(axis=0)))
    assert measured[()][0] < 0 < PRESS_COSINE - 0.05 < measured[("press",)][0], measured
    assert measured[("balance",)][1] < 0.75 * measured[()][1], measured


def test_starting_postures_are_found_for_other_sizes():
    """A new object's starts are searched (said in a warning), each a valid grasp, and kept for the next process; a
    damaged stored file is named, searched again and replaced. The paper's family (four designs, half a second)
    goes the way the grasp-types family does (`tests/test_last_bits.py` searches that one; its bar shows after
    2 s, which this search does not last)."""
    import subprocess
    import sys

    from graspmanifold.synthesis import start_cache
    from graspmanifold.synthesis.start_cache import cache_directory
    from graspmanifold.synthesis.starts import is_design_grasp

    obj = gm.make_object("cylinder", radius=0.025, length=0.12)
    with pytest.warns(UserWarning, match="no shipped starting postures"):
        starts = gm.starting_postures(obj, "five_fingertip")
    assert len(starts) >= 3 and all(is_design_grasp(obj, start) for start in starts)
    # stored for the next process: a second one reads them (no search, no warning) and gets the same grasps
    code = ("import warnings, numpy as np, graspmanifold as gm; warnings.simplefilter('error'); "
            "obj = gm.make_object('cylinder', radius=0.025, length=0.12); "
            "print(np.concatenate([s.posture for s in gm.starting_postures(obj, 'five_fingertip')]).tolist())")
    again = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert again.returncode == 0, again.stderr
    np.testing.assert_array_equal(eval(again.stdout), np.concatenate([s.posture for s in starts]))
    stored = [start_cache.starts_cache_path(obj, "five_fingertip")]
    assert stored[0].parent == cache_directory() / "starting_postures" and stored[0].exists()
    # a damaged stored file is named, searched again and replaced
    stored[0].write_bytes(stored[0].read_bytes()[:100])
    start_cache._starting_postures.cache_clear()
    with pytest.warns(UserWarning, match="cannot be read"):
        searched = gm.starting_postures(obj, "five_fingertip")
    np.testing.assert_array_equal([s.posture for s in searched], [s.posture for s in starts])
    assert gm.io.load_npz(stored[0], "starting_postures", {})[1]["objects"]


def test_a_users_own_starting_postures_are_the_ones_explored_and_bad_ones_are_refused():
    from dataclasses import replace

    tripod = next(s for s in gm.starting_postures("cylinder", "grasp_types") if s.name == "tripod")
    mine = replace(tripod, name="my_tripod")
    postures = gm.generate_postures("cylinder", 4, seed=0, workers=1, starts=[mine], progress=False)
    assert len(postures) == 4 and postures.start_names == ("cylinder:my_tripod",)
    assert postures.metadata["kept_by_start"] == {"my_tripod": 4}
    assert postures.metadata["grasp_types"] == {"my_tripod": "tripod"}
    with pytest.raises(ValueError, match=r"starts\[0\] \('my_tripod'\)\.posture must be 22 finite numbers"):
        gm.generate_postures("cylinder", 4, starts=[replace(mine, posture=mine.posture[:20])])
    with pytest.raises(ValueError, match=r"starts\[0\] \('my_tripod'\) is not a grasp of cylinder"):
        gm.generate_postures("cylinder", 4, starts=[replace(mine, hand_pos=mine.hand_pos + [0.0, 0.0, 0.3])])
    with pytest.raises(ValueError, match="names of their own"):
        gm.generate_postures("cylinder", 4, starts=[mine, mine])
    with pytest.raises(ValueError, match="non-empty list"):
        gm.generate_postures("cylinder", 4, starts=[])


@pytest.fixture(scope="module")
def small_sets():
    return {name: gm.generate_postures(name, 24, seed=3, params=SMALL) for name in ("box", "cylinder", "sphere")}


@pytest.mark.parametrize("name", ["box", "cylinder", "sphere"])
def test_every_generated_posture_replays_as_a_valid_grasp(small_sets, name):
    postures = small_sets[name]
    assert len(postures) == 24
    assert len(np.unique(postures.start_ids)) >= 3
    for posture, pose in zip(postures.postures, postures.hand_poses):
        assert_valid_grasp(name, posture, pose)
    distal = [gm.SEGMENTS.index(s) for s in gm.DISTAL_SEGMENTS]
    assert postures.contacts[:, distal].all()
    assert postures.metadata["object"] == gm.get_object(name).params()
    assert 0 < postures.metadata["acceptance_ratio"] <= 1


def replay_holds(obj, posture, pose) -> bool:
    """The generator's verification by hand: the open-loop grasp made from the posture's contacts (the pregrasp
    2 cm out along the normals, the squeeze 1 cm in) replayed on the free object, gravity in six directions."""
    from graspmanifold.judging.plans import GRASP_STAGES, open_loop_grasp
    from graspmanifold.judging.replay import replay

    grasp = open_loop_grasp(pose, posture, GRASP_STAGES["contacts"], gm.Scene(obj))
    return bool(replay(obj, [grasp], "hold-test")[0][0])


def test_a_stored_experience_posture_is_a_verified_grasp():
    """With verification (the default) the generator draws candidates until n of them hold the object
    when replayed, and every kept posture does."""
    quick = gm.GeneratorParams(job_size=6, max_candidates_per_posture=10)  # a design that never holds gives up soon
    verified = gm.generate_postures("box", 12, seed=0, params=quick)
    meta = verified.metadata
    assert len(verified) == 12 and meta["verified"] and meta["candidates"] > 12  # some candidates drop the box
    assert 0 < meta["verified_ratio"] < 1 and sum(meta["kept_by_start"].values()) == 12
    assert np.all(verified.epsilon >= 0) and np.all(verified.hold_displacement <= 0.02)
    for posture, pose in zip(verified.postures, verified.hand_poses):
        assert replay_holds("box", posture, pose)
    unverified = gm.generate_postures("box", 12, seed=0, params=SMALL)
    assert len(unverified) == 12 and np.all(np.isnan(unverified.epsilon))


def test_verifying_candidates_afterwards_keeps_those_the_generator_keeps():
    """The walk does not depend on the verification: the candidates of the unverified run, verified
    afterwards, are what the verifying generator keeps of its first wave."""
    candidates = gm.generate_postures("cylinder", 8, seed=0, params=SMALL)
    kept = generator.verify_postures(candidates, "cylinder")
    assert kept.metadata["candidates"] == 8 and kept.metadata["verified_ratio"] == len(kept) / 8
    held = [any(np.array_equal(p, q) for q in kept.postures) for p in candidates.postures]
    assert sum(held) == len(kept) and np.all(np.isfinite(kept.epsilon))
    verified = gm.generate_postures("cylinder", 8, seed=0,
                                    params=gm.GeneratorParams(job_size=6, max_candidates_per_posture=10,
                                                              designs="five_fingertip"))  # SMALL's starts
    for start in np.unique(kept.start_ids):  # each start's kept postures come first, in the same order
        mine, theirs = kept.postures[kept.start_ids == start], verified.postures[verified.start_ids == start]
        assert np.array_equal(theirs[: len(mine)], mine[: len(theirs)])


def test_too_low_a_yield_raises_naming_it():
    """Asking for postures that the budget of candidates cannot verify fails with the yield per start."""
    with pytest.raises(generator.GenerationError, match=r"only \d+ of the 40 sphere postures.*yield.*by starting "
                       r"posture: power \d+ of \d+"):
        gm.generate_postures("sphere", 40, seed=0, params=gm.GeneratorParams(job_size=10, max_candidates_per_posture=1))


def test_a_precision_grasp_of_a_small_ball_is_generated_and_holds():
    """Every grasp type has its design: a 2 cm ball is pinched between the thumb's and the index finger's
    tips, the other fingers curled away, and the grasp holds when replayed."""
    marble = gm.make_object("sphere", radius=0.01, mass=0.01, name="marble")
    starts = {s.name: s for s in gm.starting_postures(marble, "grasp_types")}
    assert {"pinch", "tripod", "lateral"} <= set(starts)
    assert starts["pinch"].grasp_type == "precision" and starts["pinch"].contacts == ("ffdistal", "thdistal")
    params = gm.GeneratorParams(designs="grasp_types", job_size=4)
    postures = gm.generate_postures(marble, 6, seed=0, params=params)  # one of each grasp type first
    assert len(postures) == 6 and postures.metadata["grasp_types"]["pinch"] == "precision"
    kept = {postures.metadata["grasp_types"][name] for name, k in postures.metadata["kept_by_start"].items() if k}
    assert kept == {"precision", "tripod", "lateral"}
    postures = gm.generate_postures(marble, 3, seed=0, params=params, starts=[starts["pinch"]])
    pinch = postures.start_ids == 0
    assert pinch.all() and postures.start_names == ("marble:pinch",)
    for posture, pose, touching in zip(postures.postures[pinch], postures.hand_poses[pinch], postures.contacts[pinch]):
        assert touching[gm.SEGMENTS.index("ffdistal")] and touching[gm.SEGMENTS.index("thdistal")]
        assert replay_holds(marble, posture, pose)


def test_same_seed_same_set_whatever_the_worker_count(small_sets):
    again = gm.generate_postures("cylinder", 24, seed=3, params=SMALL, workers=2)
    first = small_sets["cylinder"]
    assert again.postures.tobytes() == first.postures.tobytes()
    assert again.hand_poses.tobytes() == first.hand_poses.tobytes()
    other = gm.generate_postures("cylinder", 24, seed=4, params=SMALL)
    assert other.postures.tobytes() != first.postures.tobytes()


def test_recording_mode_records_along_the_motion():
    """The paper's procedure: postures recorded every few physics steps while the hand glides and dwells
    lie much closer together than one settled posture per walk step, and each is still a valid grasp."""
    recording = gm.GeneratorParams(job_size=6, verify=False, mode="recording")
    recorded = gm.generate_postures("cylinder", 24, seed=0, params=recording)
    settled = gm.generate_postures("cylinder", 24, seed=0, params=SMALL)
    assert len(recorded) == 24 and recorded.metadata["generator"]["mode"] == "recording"
    spacing = [nearest_neighbour_deg(s.postures)["median"] for s in (recorded, settled)]
    assert spacing[0] < spacing[1] / 3, spacing
    again = gm.generate_postures("cylinder", 24, seed=0, params=recording, workers=2)
    assert again.postures.tobytes() == recorded.postures.tobytes()
    for k in (0, 11, 23):
        assert_valid_grasp(gm.get_object("cylinder"), recorded.postures[k], recorded.hand_poses[k])
    with pytest.raises(ValueError, match="GeneratorParams.mode"):
        gm.GeneratorParams(mode="video")


def test_fewer_postures_than_starting_postures():
    """Two candidates from four starting postures: the starts without a share are left out of the metadata."""
    postures = gm.generate_postures("cylinder", 2, seed=0, params=SMALL)
    assert len(postures) == 2
    assert len(postures.metadata["verified_by_start"]) == 2


def test_data_clusters_around_the_starting_postures():
    postures = gm.generate_postures("cylinder", 80, seed=0, params=SMALL)
    separation = postures.cluster_separation()
    assert separation["starts"] >= 3
    assert separation["ratio"] < 0.5, separation


def test_interrupted_run_resumes_without_redoing_finished_jobs(tmp_path, monkeypatch):
    checkpoints = tmp_path / "parts"
    calls = []
    real_run = generator.walk

    def counting_run(obj, start, job, seed, params, hand):
        calls.append(job)
        if len(calls) == 4:
            raise KeyboardInterrupt  # the run is killed half-way
        return real_run(obj, start, job, seed, params, hand)

    monkeypatch.setattr(generator, "walk", counting_run)
    with pytest.raises(KeyboardInterrupt):
        gm.generate_postures("sphere", 24, seed=1, params=SMALL, checkpoint_dir=checkpoints)
    finished = sorted(p.name for p in checkpoints.glob("job_*.npz"))
    assert len(finished) == 3
    assert not list(checkpoints.glob("*.tmp"))  # nothing half-written
    calls.clear()
    monkeypatch.setattr(generator, "walk", lambda *a: calls.append(a[2]) or real_run(*a))
    resumed = gm.generate_postures("sphere", 24, seed=1, params=SMALL, checkpoint_dir=checkpoints)
    assert len(calls) == 1  # only the unfinished job ran
    fresh = gm.generate_postures("sphere", 24, seed=1, params=SMALL)
    assert resumed.postures.tobytes() == fresh.postures.tobytes()
    (checkpoints / "job_009_0000.npz").write_bytes(b"truncated")  # a broken leftover part
    with pytest.warns(UserWarning, match="discarded 5 checkpoint part"):  # parts of seed 1 are not reused
        other_seed = gm.generate_postures("sphere", 24, seed=2, params=SMALL, checkpoint_dir=checkpoints)
    assert other_seed.postures.tobytes() == gm.generate_postures("sphere", 24, seed=2, params=SMALL).postures.tobytes()


def test_an_empty_set_has_no_clusters(small_sets):
    """A preset can leave an object without one verified posture; its statistics say so instead of failing."""
    empty = small_sets["cylinder"][np.zeros(len(small_sets["cylinder"]), dtype=bool)]
    separation = empty.cluster_separation()
    assert len(empty) == 0 and separation["starts"] == 0 and np.isnan(separation["within_deg"])
    assert np.isnan(nearest_neighbour_deg(empty.postures)["min"])


def test_posture_set_files_round_trip_and_concatenate(small_sets, tmp_path):
    box, cylinder = small_sets["box"], small_sets["cylinder"]
    path = cylinder.save(tmp_path / "cylinder.npz")
    loaded = gm.PostureSet.load(path)
    assert loaded.postures.tobytes() == cylinder.postures.tobytes()
    assert loaded.start_names == cylinder.start_names and loaded.metadata["seed"] == 3
    both = gm.PostureSet.concatenate([box, cylinder])
    assert len(both) == 48 and len(both.start_names) == len(box.start_names) + len(cylinder.start_names)
    np.testing.assert_array_equal(np.array(both.start_names)[both.start_ids[24:]],
                                  np.array(cylinder.start_names)[cylinder.start_ids])
    assert len(cylinder.subset(cylinder.start_ids == 0)) == np.sum(cylinder.start_ids == 0)


def test_corrupt_and_inconsistent_set_files_raise(small_sets, tmp_path):
    good = small_sets["sphere"].save(tmp_path / "s.npz")
    broken = tmp_path / "broken.npz"
    broken.write_bytes(good.read_bytes()[:300])
    with pytest.raises(ValueError, match="truncated or corrupt"):
        gm.PostureSet.load(broken)
    with pytest.raises(ValueError, match="hand_poses"):
        gm.PostureSet(np.zeros((2, 22)), np.zeros((3, 7)), np.zeros(2, int), np.zeros((2, len(gm.SEGMENTS)), bool), ("a",))


@pytest.mark.parametrize("call, message", [
    (lambda: gm.generate_postures("cylinder", 0), "n must be a whole number in 1 ... 1000000"),
    (lambda: gm.generate_postures("cylinder", -5), "n must be a whole number in 1 ... 1000000"),
    (lambda: gm.generate_postures("teapot", 10), "unknown object"),
    (lambda: gm.generate_postures("cylinder", 10, workers=0), "workers"),
])
def test_bad_generator_arguments_raise(call, message):
    with pytest.raises(ValueError, match=message):
        call()


def test_cli_generates_and_refuses_to_overwrite(tmp_path, capsys):
    out = tmp_path / "data" / "sphere.npz"
    assert cli(["generate", "--object", "sphere", "--n", "8", "--no-verify", "--out", str(out)]) == 0
    assert len(gm.PostureSet.load(out)) == 8
    assert not (tmp_path / "data" / "sphere.npz.parts").exists()
    before = out.read_bytes()
    with pytest.raises(SystemExit, match="exists; pass --force"):
        cli(["generate", "--object", "sphere", "--n", "8", "--no-verify", "--out", str(out)])
    assert out.read_bytes() == before
    with pytest.raises(SystemExit, match="--n must be a whole number in 1"):
        cli(["generate", "--object", "sphere", "--n", "0", "--out", str(tmp_path / "x.npz")])
    with pytest.raises(SystemExit, match="must end in .npz"):
        cli(["generate", "--object", "sphere", "--n", "4", "--out", str(tmp_path / "x.csv")])
    blocker = tmp_path / "file"
    blocker.write_text("not a directory")
    with pytest.raises(SystemExit, match="cannot write"):
        cli(["generate", "--object", "sphere", "--n", "4", "--out", str(blocker / "x.npz")])
    with pytest.raises(SystemExit):
        cli(["generate", "--object", "teapot", "--out", str(tmp_path / "y.npz")])
    assert not (tmp_path / "x.npz").exists() and not (tmp_path / "y.npz").exists()


def test_a_new_objects_slow_set_up_and_a_verification_that_keeps_few_are_announced(monkeypatch):
    """A mesh torus's starting postures took 148 s in silence, and a verification that kept 1 of 20 said nothing."""
    from graspmanifold.synthesis import generator

    with pytest.warns(UserWarning, match="no shipped starting postures .* searching them now"):
        gm.starting_postures(gm.make_object("cylinder", radius=0.026, length=0.13))
    assert len(gm.starting_postures(gm.make_object("cylinder", friction=0.3))) == len(gm.starting_postures("cylinder"))
    candidates = gm.generate_postures("sphere", 6, params=gm.GeneratorParams(verify=False,
                                                                             job_size=6))
    monkeypatch.setattr(generator, "FEW_HOLD", 1.01)  # whatever holds, it is "few"
    with pytest.warns(UserWarning, match=r"only \d+ of 6 sphere candidates hold"):
        gm.verify_postures(candidates, "sphere")


def test_springs_that_break_the_physics_are_named_not_reported_as_a_low_yield():
    """A spring stiffness of 1e12 gave 40 MuJoCo warnings, then 'only 0 of 8 ... keep every candidate
    (verify=False)' without naming the faults, though verification was already off."""
    params = gm.GeneratorParams(spring_stiffness=1e12, spring_max_force=1e9, job_size=4, verify=False,
                                max_tries_per_posture=3)
    with pytest.raises(generator.GenerationError, match=r"simulation failed \d+ times in \d+ walk steps \(first: "
                       r"MuJoCo warning \w+.*spring_stiffness 1e\+12 N/m") as raised:
        gm.generate_postures("cylinder", 4, seed=0, params=params)
    assert "verify=False" not in str(raised.value)


def test_an_object_wider_than_the_hand_spans_is_refused_with_its_size_before_any_search():
    """A 30 cm box: no design can close around it, and the message says why in sizes, at once."""
    import time

    import trimesh
    from scipy.spatial.transform import Rotation

    from graspmanifold.sim.hand_models import hand_model

    hand = hand_model("shadow-primitives")
    assert 0.18 < hand.span < 0.26  # thumb tip to little fingertip, the hand open
    started = time.perf_counter()
    with pytest.raises(gm.GenerationError, match=r"30\.0 cm across at its narrowest.*spans 22\.0 cm"):
        gm.generate_postures(gm.make_object("box", size=(0.3, 0.3, 0.3)), 5, progress=False)
    assert time.perf_counter() - started < 5  # before the starting-posture search (minutes for such a box)
    plank = trimesh.creation.box(extents=(0.12, 0.07, 0.02))
    plank.apply_transform(np.block([[Rotation.from_euler("xyz", [0.4, 0.3, 0.2]).as_matrix(), np.zeros((3, 1))],
                                    [np.zeros((1, 3)), np.ones((1, 1))]]))
    assert gm.make_object("mesh", mesh=plank).narrowest_width == pytest.approx(0.02, rel=1e-6)  # turned: not its box
    assert gm.get_object("cylinder").narrowest_width == pytest.approx(0.06)
