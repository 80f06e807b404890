"""What `generate_postures(obj, n)` gives with its defaults: the designs, their grasp types and verified shares.

A thin command over `graspmanifold.studies.generator_defaults`, whose docstring says what it runs and writes; `--help` lists
its options.
"""

from graspmanifold.studies.generator_defaults import main

if __name__ == "__main__":
    main()
