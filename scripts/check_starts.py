"""Does the start search turn on the last bits: a thin command over `graspmanifold.studies.starts_agreement`."""

from graspmanifold.studies.starts_agreement import main

if __name__ == "__main__":
    main()
