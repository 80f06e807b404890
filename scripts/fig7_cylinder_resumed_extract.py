"""Fig. 7: the cylinder map extract after resumed learning (from a `graspmanifold reproduce` run; PNG and PDF).

    python scripts/fig7_cylinder_resumed_extract.py RUN_DIR [--out DIR]
"""

from graspmanifold.report import figure_script

figure_script("fig7_cylinder_resumed_extract", __doc__)
