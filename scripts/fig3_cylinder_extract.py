"""Fig. 3: a 10 x 10 extract of the cylinder map as hand pictures (from a `graspmanifold reproduce` run; PNG and PDF).

    python scripts/fig3_cylinder_extract.py RUN_DIR [--out DIR]
"""

from graspmanifold.report import figure_script

figure_script("fig3_cylinder_extract", __doc__)
