"""A researcher's first hour with the library, as one script (issues 25 and 40): objects, pictures, postures, a
SOM, an evaluation, a GIF, a custom pose, another friction, a paired comparison; then their own work: a mesh of
their own from a file in millimetres, a hand file of their own edited and loaded again, an experience of their
own that blends postures, the trials as a DataFrame, and an experiment file. `tests/test_first_hour.py` runs it
from a fresh interpreter in an empty directory outside the checkout; run it yourself the same way:

    cd /tmp && python /path/to/graspmanifold/tests/first_hour.py

Each step checks what a researcher would look at, and the script says what it did.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import trimesh

import graspmanifold as gm
from graspmanifold.trials.stats import compare

gm.show_progress(False)  # a script's log, not bars

# objects: the paper's three, and what they are
for name in ("box", "cylinder", "sphere"):
    obj = gm.get_object(name)
    assert obj.friction == 0.6 and obj.half_extents.max() <= 0.08, obj
print("objects:", ", ".join(repr(gm.get_object(n)) for n in ("box", "cylinder", "sphere")))

# pictures: a scene from a named camera, the second picture from the kept drawing process
scene = gm.Scene("cylinder")
scene.set_hand_pose(*gm.facing_pose("cylinder"))
picture = scene.render("front", 160, 120)
assert picture.shape == (120, 160, 3) and picture.std() > 10
assert np.array_equal(scene.render("front", 160, 120), picture)
print("pictures: the front camera draws the same scene the same way twice")

# postures: spring-generated grasps, every one with its five fingertips on the cylinder
postures = gm.generate_postures("cylinder", 24, seed=0, params=gm.GeneratorParams(verify=False, job_size=12))
distal = [gm.SEGMENTS.index(s) for s in gm.DISTAL_SEGMENTS]
assert len(postures) == 24 and postures.contacts[:, distal].all()
print(f"postures: {postures}")

# a SOM on them, and the masked best match of a partial contact posture
som = gm.SOM(8, 8, 22, seed=0).fit(postures.postures, epochs=30)
mask = gm.pcp_mask(["thdistal", "ffdistal"])
node = som.best_match(postures.postures[0], mask)
assert 0 <= node < 64 and som.quantization_error(postures.postures) < 0.2
print(f"SOM: {som.rows}x{som.cols}, quantisation error {som.quantization_error(postures.postures):.3f} rad")

# an evaluation on a few poses of the quick grid
grid = gm.grid_preset("quick", "cylinder")[::5]
heuristic = gm.evaluate("cylinder", None, grid, seed=0)
with_som = gm.evaluate("cylinder", som, grid, seed=0)
assert len(heuristic.trials) == len(grid) and all(t.valid for t in heuristic.trials + with_som.trials)
assert all(len(t.winners) == t.matches for t in with_som.trials)
print(heuristic.markdown() + with_som.markdown())

# a GIF of one trial
recording = gm.record_trial("cylinder", som, grid_pose=(0.0, 0.0, 0.01, 0.0), every=10)
gif = recording.save_gif(Path("grasp.gif"), camera="hand", width=120, height=90)
assert gif.stat().st_size > 1000
print(f"GIF: {gif} ({gif.stat().st_size} bytes), {recording.trial}")

# a custom pose: one that can start, one that cannot, and why
assert gm.why_unreachable("cylinder", (0.005, 0.0, 0.015, -0.2)) is None
why = gm.why_unreachable("cylinder", (0.0, 0.0, -0.01, 0.0))
assert why is not None and "inside the cylinder" in why
try:
    gm.record_trial("cylinder", grid_pose=(0.0, 0.0, -0.01, 0.0))
except ValueError as error:
    assert "inside the cylinder" in str(error)
else:
    raise AssertionError("a pose inside the object was run")
custom = gm.evaluate("cylinder", None, np.array([0.005, 0.0, 0.015, -0.2]))
print(f"custom pose: {custom.trials[0]}; refused: {why}")

# another friction: a variant named after what differs, and epsilon at the simulation's friction
slippery = gm.make_object("cylinder", friction=0.3)
assert slippery.name == "cylinder_friction0.3"
trial = gm.evaluate(slippery, None, np.array([0.0, 0.0, 0.01, 0.0])).trials[0]
print(f"friction 0.3: {slippery.name}: {trial}")

# a paired comparison on the same poses, with its numbers whatever they say
paired = compare(with_som, heuristic)
assert paired.n == len(grid) and 0.0 <= paired.p_value <= 1.0
print(f"SOM against the heuristic on {paired.n} poses: {paired.only_a} held only with the SOM, {paired.only_b} only "
      f"without, McNemar p = {paired.p_value:.3g}: {paired.verdict()}")

# their own object: a rounded bottle written in millimetres, as a CAD tool writes it, loaded with its unit
trimesh.creation.capsule(height=50.0, radius=24.0).export("bottle_mm.stl")
bottle = gm.make_object("mesh", mesh="bottle_mm.stl", scale=0.001)
assert bottle.name == "bottle_mm" and 0.095 < 2 * bottle.half_extents.max() < 0.1, bottle.half_extents
poses = gm.grid_preset("quick", bottle)[::12]
on_bottle = gm.evaluate(bottle, None, poses, seed=0)
assert len(on_bottle.trials) == len(poses)
print(f"own mesh: {bottle!r}, {on_bottle.summary['hold_rate']:.0%} held on {len(poses)} poses")

# their own hand file: ours written out, a joint range narrowed, loaded; edited again and loaded again
from graspmanifold.sim.hand_models import hand_model  # noqa: E402

hand_file = Path("my_hand.xml")
original = gm.SHADOW_HAND.to_xml()
assert '<joint name="FFJ3" class="proximal"/>' in original


def with_ffj3_upper(upper: float) -> str:
    """Our hand's MJCF with FFJ3's upper limit changed (rad)."""
    return original.replace('<joint name="FFJ3" class="proximal"/>',
                            f'<joint name="FFJ3" class="proximal" range="-0.2618 {upper}"/>')


hand_file.write_text(with_ffj3_upper(1.0))
first = hand_model(hand_file)
hand_file.write_text(with_ffj3_upper(0.8))  # edited in place: the next load reads it again
second = hand_model(hand_file)
row = gm.FINGER_JOINTS.index("FFJ3")
assert np.isclose(first.limits()[row, 1], 1.0) and np.isclose(second.limits()[row, 1], 0.8)
narrow = gm.evaluate("cylinder", None, grid[:2], seed=0, hand=hand_file)
assert all(t.posture[row] <= 0.8 + 0.05 for t in narrow.trials)
print(f"own hand: FFJ3 up to {first.limits()[row, 1]:.2f}, then {second.limits()[row, 1]:.2f} rad after the edit")


# their own experience: the mean of the three nearest postures under the PCP mask (Eq. 2), not the nearest alone
class Blend:
    def __init__(self, postures: np.ndarray):
        self.references, self.dim = postures, postures.shape[1]

    def distances(self, x, mask):
        p = np.ones(self.dim) if mask is None else np.asarray(mask, dtype=float)
        return (p * (self.references - np.where(p > 0, x, 0.0)) ** 2).sum(axis=1)

    def best_match(self, x, mask=None):
        return int(np.argmin(self.distances(x, mask)))

    def complete(self, x, mask=None):
        return self.references[np.argsort(self.distances(x, mask))[:3]].mean(axis=0)

    def best_match_batch(self, X, masks=None):
        return np.array([self.best_match(x, m) for x, m in zip(X, np.broadcast_to(masks, X.shape))]) \
            if masks is not None else np.array([self.best_match(x) for x in X])

    def complete_batch(self, X, masks=None):
        return np.array([self.complete(x, None if masks is None else m)
                         for x, m in zip(X, np.broadcast_to(1.0 if masks is None else masks, X.shape))])


from graspmanifold.trials.conformance import check_experience_contract  # noqa: E402

blend = Blend(postures.postures)
check_experience_contract(blend)
assert not np.allclose(blend.complete(postures.postures[0], mask), postures.postures[blend.best_match(postures.postures[0], mask)])
blended = gm.evaluate("cylinder", blend, grid, seed=0)
assert any(t.matches for t in blended.trials)
print(f"own experience: {blended.summary['hold_rate']:.0%} held recalling blends, "
      f"{with_som.summary['hold_rate']:.0%} with the SOM")

# the trials as a table: a DataFrame for pandas, a CSV for anything else
frame = blended.to_frame()
assert len(frame) == len(grid) and {"hold", "x", "matches"} <= set(frame.columns), list(frame.columns)
blended.to_csv("blended.csv")
print(f"table: {frame.shape[0]} rows x {frame.shape[1]} columns, e.g. {', '.join(list(frame.columns)[:5])}")

# an experiment file: the reproduction's configuration read from TOML, an unknown key named, written back out
from graspmanifold.base.config_files import read_config, to_toml  # noqa: E402
from graspmanifold.paper.reproduce import PRESETS  # noqa: E402

Path("run.toml").write_text('grid = "quick"\npostures = { box = 30, cylinder = 30, sphere = 30 }\n'
                            '[generator]\nverify = true\n')
config = read_config("run.toml", PRESETS["quick"])
assert config.grid == "quick" and config.postures["box"] == 30 and config.generator.verify
Path("typo.toml").write_text("grids = 'quick'\n")
try:
    read_config("typo.toml", PRESETS["quick"])
except ValueError as error:
    assert "unknown key grids" in str(error), error
else:
    raise AssertionError("a misspelt key was taken")
Path("again.toml").write_text(to_toml(config))
assert read_config("again.toml", PRESETS["quick"]) == config
print("experiment file: read, checked and written back (graspmanifold reproduce --config run.toml runs it)")
print("first hour: done")
