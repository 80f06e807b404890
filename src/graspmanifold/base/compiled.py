"""The library's compiled code (numba): one switch for all of it and one way to compile a kernel.

Every compiled kernel (the SOM's and the nearest search's in `manifold.kernels`, a mesh's queries in
`sim.mesh_queries`) has a NumPy reference beside it; `GRASPMANIFOLD_COMPILED=0` in the environment (read when first
asked) makes the library use the references, and `use_compiled` switches this process (and the workers it forks
afterwards; a Dask worker reads the environment) at run time. Compiled code is cached on disk (numba's
`cache=True`): the first call in a fresh environment compiles for a few seconds, later processes load it; where
numba finds no writable place for its cache (a read-only install without a writable HOME or NUMBA_CACHE_DIR), a
kernel compiles in memory instead.
"""

from __future__ import annotations

from collections.abc import Callable

from numba import njit

from .validation import env_switch

_enabled: bool | None = None  # set by use_compiled; until then GRASPMANIFOLD_COMPILED says


def compiled() -> bool:
    """Whether the library uses its compiled kernels.

    Returns:
        True unless switched off (`use_compiled`, or GRASPMANIFOLD_COMPILED=0).
    """
    return env_switch("GRASPMANIFOLD_COMPILED") if _enabled is None else _enabled


def use_compiled(enabled: bool) -> bool:
    """Switch the compiled kernels on or off (off: the NumPy references).

    Args:
        enabled: on or off.

    Returns:
        The previous setting.
    """
    global _enabled
    previous, _enabled = compiled(), bool(enabled)
    return previous


def compiled_kernel(function: Callable) -> Callable:
    """`function` compiled without the GIL, its machine code cached on disk where numba can write a cache.

    Args:
        function: a function numba compiles (`njit`).

    Returns:
        The compiled function.
    """
    try:
        return njit(cache=True, nogil=True)(function)
    except RuntimeError:  # "cannot cache function ...: no locator available": compile in memory
        return njit(nogil=True)(function)
