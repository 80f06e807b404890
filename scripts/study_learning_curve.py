"""The learning curve (issue 51): a thin command over `graspmanifold.studies.learning_curve`."""

from graspmanifold.studies.learning_curve import main

if __name__ == "__main__":
    main()
