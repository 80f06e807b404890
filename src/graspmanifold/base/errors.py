"""The library's errors: one base class, `GraspManifoldError`, so that a caller (the `graspmanifold`
command among them) can tell the library's refusals and failures from bugs with one `except`.

Each error also derives from the built-in exception a Python user would expect of it
(`InvalidInput` is a `ValueError`, the failures are `RuntimeError`s), so code written against the
built-ins keeps working.
"""


class GraspManifoldError(Exception):
    """Base class of every error the library raises on purpose."""


class InvalidInput(GraspManifoldError, ValueError):
    """An argument, a value or a file that is not what was expected; the message names it and says
    what was expected."""


class MissingFile(InvalidInput, FileNotFoundError):
    """A file to read that is not there: an `InvalidInput` (the message names the argument) and a
    `FileNotFoundError`."""

    def __init__(self, message: str, path: str) -> None:
        InvalidInput.__init__(self, message)
        self.filename, self.strerror = path, message

    def __str__(self) -> str:
        return str(self.strerror)


class NotFittedError(GraspManifoldError, RuntimeError, AttributeError):
    """A model (a SOM) used before it was fitted. An `AttributeError` too, so `hasattr` and protocol
    checks (`isinstance(som, Experience)`) read an unfitted map as lacking what fitting gives it."""


class SimulationError(GraspManifoldError, RuntimeError):
    """The physics failed: MuJoCo raised a warning (it resets a diverging state) or the state is not finite."""


class QualityError(GraspManifoldError, RuntimeError):
    """Qhull could not build the grasp wrench space: a numerical failure, not a verdict on the grasp."""


class GenerationError(GraspManifoldError, RuntimeError):
    """The generator could not find the postures asked for (too few candidates verified, or none found)."""


class WorkersLost(GraspManifoldError, RuntimeError):
    """The worker processes or the cluster running a job are gone, and starting again did not help."""


class OutputInUse(GraspManifoldError, RuntimeError):
    """Another graspmanifold process is writing the same output."""


class RenderingUnavailable(GraspManifoldError, RuntimeError):
    """No offscreen OpenGL context could be created."""


class BackendUnavailable(GraspManifoldError, RuntimeError):
    """A compute backend asked for (MuJoCo Warp on a GPU) cannot run on this machine."""
