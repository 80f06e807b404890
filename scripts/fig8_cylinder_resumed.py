"""Fig. 8 a/b/c: the cylinder map after resumed learning (from a `graspmanifold reproduce` run; PNG and PDF).

    python scripts/fig8_cylinder_resumed.py RUN_DIR [--out DIR]
"""

from graspmanifold.report import figure_script

figure_script("fig8_cylinder_resumed", __doc__)
