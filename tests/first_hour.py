"""A researcher's first hour with the library, as one script (issue 25): objects, pictures, postures, a SOM,
an evaluation, a GIF, a custom pose, another friction, a paired comparison. `tests/test_first_hour.py` runs it
from a fresh interpreter in an empty directory outside the checkout; run it yourself the same way:

    cd /tmp && python /path/to/graspmanifold/tests/first_hour.py

Each step checks what a researcher would look at, and the script says what it did.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

import graspmanifold as gm
from graspmanifold.trials.study import compare

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
print("first hour: done")
