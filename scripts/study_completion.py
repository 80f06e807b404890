"""The completion study (`graspmanifold.studies.completion`: its docstring says what it runs, `--help` its options)."""
from graspmanifold.studies.completion import main
if __name__ == "__main__":
    main()
