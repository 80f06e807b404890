"""Fig. 4 a/b: inter-node distances and training-data nodes of the box map (from a `graspmanifold reproduce` run; PNG and PDF).

    python scripts/fig4_box.py RUN_DIR [--out DIR]
"""

from graspmanifold.report import figure_script

figure_script("fig4_box", __doc__)
