"""The learning curve: does the hold rate grow with the experience, generated and the controller's own?

A thin command over `graspmanifold.studies.learning_curve`, whose docstring says what it runs and writes; `--help`
lists its options.
"""

from graspmanifold.studies.learning_curve import main

if __name__ == "__main__":
    main()
