"""The first experience study, on the paper's grids: does recalling experienced grasps beat the strongest

A thin command over `graspmanifold.studies.paper_grids`, whose docstring says what it runs and writes; `--help` lists
its options.
"""

from graspmanifold.studies.paper_grids import main

if __name__ == "__main__":
    main()
