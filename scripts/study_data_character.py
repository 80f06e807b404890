"""Which generator mode gives data of the paper's character? Data statistics and map distances per mode.

A thin command over `graspmanifold.studies.data_character`, whose docstring says what it runs and writes; `--help` lists
its options.
"""

from graspmanifold.studies.data_character import main

if __name__ == "__main__":
    main()
