"""Fig. 5: two 1 x 4 extracts across a cluster border (from a `graspmanifold reproduce` run; PNG and PDF).

    python scripts/fig5_cylinder_border.py RUN_DIR [--out DIR]
"""

from graspmanifold.report import figure_script

figure_script("fig5_cylinder_border", __doc__)
