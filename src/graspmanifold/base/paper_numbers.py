"""The numbers of the paper, "SOM-based experience representation for dextrous grasping" (WSOM 2007),
in one place: what the library reproduces and what its verdicts compare against (Section 5).
"""

#: the object of the figures that show one map (Figs. 3 and 5-8)
FIGURE_OBJECT = "cylinder"
#: postures recorded per object
DATASET_SIZES: dict[str, int] = {"box": 4069, "cylinder": 4220, "sphere": 1885}
#: the SOM's lattice: rows x columns of nodes
MAP_SIZE: tuple[int, int] = (25, 25)
#: the smallest angle between neighbouring nodes of each object's map, degrees
MIN_DISTANCE_DEG: dict[str, float] = {"box": 0.013, "cylinder": 0.013, "sphere": 0.007}
#: the largest angle between neighbouring nodes of each object's map, degrees
MAX_DISTANCE_DEG: dict[str, float] = {"box": 55.06, "cylinder": 63.45, "sphere": 66.23}
#: the training schedule of a map (Section 4): epochs, learning rate and neighbourhood width (in nodes),
#: each decaying from its first value to its second
TRAINING_SCHEDULE: tuple[int, tuple[float, float], tuple[float, float]] = (300, (0.95, 0.05), (6.0, 0.7))
#: the schedule of resumed learning with the successful grasps (Section 5, Figs. 7 and 8)
RESUME_SCHEDULE: tuple[int, tuple[float, float], tuple[float, float]] = (10, (0.1, 0.05), (3.0, 0.7))
