"""Why the paper's literal controller loses where the blend holds: traced trials of three readings of the recall.

A thin command over `graspmanifold.studies.recall_trace`, whose docstring says what it runs and prints; `--help`
lists its options.
"""

from graspmanifold.studies.recall_trace import main

if __name__ == "__main__":
    main()
