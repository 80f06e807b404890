"""Whether the start search's outcome turns on the last bits: the shipped starting postures, searched again.

A thin command over `graspmanifold.studies.starts_agreement`, whose docstring says what it runs and writes; `--help`
lists its options.
"""

from graspmanifold.studies.starts_agreement import main

if __name__ == "__main__":
    main()
