"""The library on the community's Shadow Hands beside ours: the cross-model table (issue 28).

A thin command over `graspmanifold.studies.hands`, whose docstring says what it runs and writes; `--help` lists
its options.
"""

from graspmanifold.studies.hands import main

if __name__ == "__main__":
    main()
