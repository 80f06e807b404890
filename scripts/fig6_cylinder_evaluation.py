"""Fig. 6: the cylinder map with the nodes of successful evaluation grasps (from a `graspmanifold reproduce` run; PNG and PDF).

    python scripts/fig6_cylinder_evaluation.py RUN_DIR [--out DIR]
"""

from graspmanifold.report import figure_script

figure_script("fig6_cylinder_evaluation", __doc__)
