"""force-closure and hold rates per object and method (from a `graspmanifold reproduce` run; PNG and PDF).

    python scripts/rates.py RUN_DIR [--out DIR]
"""

from graspmanifold.report import figure_script

figure_script("rates", __doc__)
