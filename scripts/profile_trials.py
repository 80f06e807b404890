"""Where a trial's time goes: physics steps and seconds per phase, on one core, in this process.

A thin command over `graspmanifold.studies.trial_profile`, whose docstring says what it runs and writes; `--help` lists
its options.
"""

from graspmanifold.studies.trial_profile import main

if __name__ == "__main__":
    main()
