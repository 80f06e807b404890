"""An object family to test grasping on, built in code with trimesh (no downloaded files).

Six shapes, each in three sizes (`SIZES`: 0.8, 1 and 1.2 times the medium one), named
`<shape>_<size>` (`capsule_m`, `ring_l`, ...), plus the paper's box, cylinder and sphere sampled as
meshes (`box_mesh`, `cylinder_mesh`, `sphere_mesh`) so that the mesh and the primitive paths can be
compared on the same solid. Medium sizes (m):

- capsule: radius 0.025, 0.10 between the cap centres (0.15 long);
- ellipsoid: semi-axes 0.025, 0.035, 0.06;
- frustum: radii 0.035 (bottom) and 0.02 (top), 0.12 high;
- bottle: a solid of revolution, body radius 0.03 over 0.10, shoulder, neck radius 0.012 over 0.03;
- ring: a torus (a ring handle), centre-line radius 0.035, tube radius 0.01 (non-convex);
- rounded_box: 0.04 x 0.06 x 0.14 with edges rounded to 0.008.

`family_mesh(name)` gives the trimesh; `objects.get_object(name)` the grasp object.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable

import numpy as np
import trimesh

from ..base.errors import InvalidInput

SIZES: dict[str, float] = {"s": 0.8, "m": 1.0, "l": 1.2}


def _capsule() -> trimesh.Trimesh:
    return trimesh.creation.capsule(height=0.10, radius=0.025, count=[24, 12])


def _ellipsoid() -> trimesh.Trimesh:
    sphere = trimesh.creation.icosphere(subdivisions=3, radius=1.0)
    sphere.apply_scale([0.025, 0.035, 0.06])
    return sphere


def _revolved(profile: list[tuple[float, float]], sections: int = 48) -> trimesh.Trimesh:
    """A solid of revolution about z from a (radius, z) profile that starts and ends on the axis."""
    return trimesh.creation.revolve(np.array(profile, dtype=float), sections=sections)


def _frustum() -> trimesh.Trimesh:
    return _revolved([(0.0, -0.06), (0.035, -0.06), (0.02, 0.06), (0.0, 0.06)])


def _bottle() -> trimesh.Trimesh:
    shoulder = [(0.012 + 0.018 * np.cos(a), 0.05 + 0.02 * np.sin(a)) for a in np.linspace(0.0, np.pi / 2, 6)]
    return _revolved([(0.0, -0.07), (0.03, -0.07), *shoulder, (0.012, 0.10), (0.0, 0.10)])


def _ring() -> trimesh.Trimesh:
    return trimesh.creation.torus(major_radius=0.035, minor_radius=0.01, major_sections=32, minor_sections=12)


def _rounded_box() -> trimesh.Trimesh:
    corner = trimesh.creation.icosphere(subdivisions=2, radius=0.008)
    inner = np.array([0.02, 0.03, 0.07]) - 0.008
    signs = itertools.product((-1.0, 1.0), repeat=3)
    return trimesh.convex.convex_hull(np.vstack([corner.vertices + inner * np.array(s) for s in signs]))


SHAPES: dict[str, Callable[[], trimesh.Trimesh]] = {
    "capsule": _capsule, "ellipsoid": _ellipsoid, "frustum": _frustum, "bottle": _bottle, "ring": _ring,
    "rounded_box": _rounded_box,
}

#: the paper's objects as meshes; the cylinder's 128 sides keep its spring statistics within 3-5 % of
#: the exact cylinder's (64 sides: 12 % fewer postures accepted; BENCHMARKS.md)
PAPER_MESHES: dict[str, Callable[[], trimesh.Trimesh]] = {
    "box_mesh": lambda: trimesh.creation.box(extents=(0.04, 0.04, 0.16)),
    "cylinder_mesh": lambda: trimesh.creation.cylinder(radius=0.03, height=0.16, sections=128),
    "sphere_mesh": lambda: trimesh.creation.icosphere(subdivisions=3, radius=0.03),
}

#: every family name: the six shapes in every size, and the paper's objects as meshes
FAMILY: tuple[str, ...] = tuple(f"{shape}_{size}" for shape in SHAPES for size in SIZES) + tuple(PAPER_MESHES)


def family_mesh(name: str) -> trimesh.Trimesh:
    """The mesh of a family member (see the module docstring)."""
    if name in PAPER_MESHES:
        return PAPER_MESHES[name]()
    shape, _, size = name.rpartition("_")
    if shape not in SHAPES or size not in SIZES:
        raise InvalidInput(f"unknown family object {name!r}; expected one of {FAMILY}")
    mesh = SHAPES[shape]()
    mesh.apply_scale(SIZES[size])
    return mesh
