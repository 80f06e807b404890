"""Grasp objects: the paper's box, cylinder and sphere, other sizes of them, and any watertight mesh.

An object is centred at its origin with its long axis along z (a mesh: at its centre of mass, on
its principal axes, see `meshes.py`). Besides what MuJoCo needs to simulate it, each object answers
the geometric queries the posture generator's springs rely on through one interface (closest
surface point, signed distance, surface normal): exact formulas for the primitives, `mesh_queries` for a mesh.
"""

from __future__ import annotations

import math
import os
import warnings
from dataclasses import dataclass, field, replace
from functools import cache, cached_property
from pathlib import Path

import numpy as np
import trimesh

from ..base.errors import InvalidInput
from .family import FAMILY, family_mesh
from .mesh_queries import MeshQueries, mesh_queries
from .meshes import MAX_EXTENT, MIN_EXTENT, load_mesh, object_geometry

SHAPES: tuple[str, ...] = ("box", "cylinder", "sphere", "mesh")

#: Sliding friction of hand and object alike: a rubber-like fingertip skin on wood or hard plastic
#: measures about 0.5-0.8; 0.6 sits inside that range. The scene gives every hand geom the object's
#: friction, so the simulation and the force-closure test (epsilon) use one coefficient.
DEFAULT_FRICTION = 0.6


@dataclass(frozen=True)
class GraspObject:
    """A rigid object. `half_sizes`: box (hx, hy, hz), cylinder (radius, half length), sphere (radius,),
    mesh (the largest |x|, |y|, |z| of its vertices). A mesh object also holds the mesh in the object
    frame and its convex parts (what MuJoCo collides); `mesh_digest` tells two meshes apart."""

    name: str
    shape: str
    half_sizes: tuple[float, ...]
    mass: float = 0.1
    friction: float = DEFAULT_FRICTION
    mesh: trimesh.Trimesh | None = field(default=None, compare=False, repr=False)
    parts: tuple[trimesh.Trimesh, ...] = field(default=(), compare=False, repr=False)
    mesh_digest: str = ""

    @property
    def half_extents(self) -> np.ndarray:
        """Half extents of the axis-aligned bounding box (3,)."""
        if self.shape in ("box", "mesh"):
            return np.array(self.half_sizes)
        if self.shape == "cylinder":
            r, h = self.half_sizes
            return np.array([r, r, h])
        return np.full(3, self.half_sizes[0])

    @cached_property
    def narrowest_width(self) -> float:
        """The object's width at its narrowest, m: the smallest extent of a primitive (a box's shortest side, a
        cylinder's diameter or length, a ball's diameter); of a mesh, the smallest extent of its convex hull
        along the hull's face normals and the frame's axes (an upper bound within a few per cent of the true
        minimum width). What a hand has to span to close around it."""
        if self.shape != "mesh":
            return float(2 * self.half_extents.min())
        assert self.mesh is not None  # a mesh object carries its mesh (`make_object`)
        hull = self.mesh.convex_hull
        directions = np.vstack([np.eye(3), hull.face_normals])
        heights = hull.vertices @ directions.T
        return float((heights.max(axis=0) - heights.min(axis=0)).min())

    def with_(self, *, mass: float | None = None, friction: float | None = None,
              name: str | None = None) -> GraspObject:
        """This object with another mass or friction, named after what differs.

        Args:
            mass: kg (default: unchanged).
            friction: the sliding friction coefficient, 0 < friction <= `MAX_FRICTION` (default: unchanged).
            name: the variant's name (default: this name and the changes, e.g. 'cylinder_friction0.3',
                so that results, files and reports show that it is not the paper's object).

        Returns:
            The variant (this object when nothing differs).
        """
        changes = {"mass": None if mass is None else _positive(mass, "mass"),
                   "friction": None if friction is None else _friction(friction)}
        differs = {k: v for k, v in changes.items() if v is not None and v != getattr(self, k)}
        if not differs and name is None:
            return self
        label = name or self.name + "".join(f"_{k}{v:g}" for k, v in differs.items())
        return replace(self, name=label, mass=differs.get("mass", self.mass),
                       friction=differs.get("friction", self.friction))

    def params(self) -> dict[str, object]:
        """Plain parameters for metadata (a mesh is named by its digest, not written out)."""
        params = {"name": self.name, "shape": self.shape, "half_sizes": list(self.half_sizes),
                  "mass": self.mass, "friction": self.friction}
        return params | ({"mesh_digest": self.mesh_digest} if self.shape == "mesh" else {})

    def signed_distance(self, points: np.ndarray) -> np.ndarray:
        """Signed distance to the surface, negative inside.

        Args:
            points: (n, 3) or (3,), m, in the object frame.

        Returns:
            Distances (n,) or a float, m.
        """
        p, single = _check_points(points)
        if self.mesh is not None:
            distance = self._surface.signed_distance(p)
        else:
            distance = _SURFACE_QUERIES[self.shape](p, self.half_sizes)[1]
        return distance[0] if single else distance

    def closest_point(self, points: np.ndarray) -> np.ndarray:
        """The closest surface points.

        Args:
            points: (n, 3) or (3,), m, in the object frame.

        Returns:
            Points on the surface, the shape of `points`, m.
        """
        p, single = _check_points(points)
        if self.mesh is not None:
            closest = self._surface.closest(p)[0]
        else:
            closest = _SURFACE_QUERIES[self.shape](p, self.half_sizes)[0]
        return closest[0] if single else closest

    def surface_normal(self, points: np.ndarray) -> np.ndarray:
        """Outward unit normals of the surface at the closest points: a mesh's face normal there, a
        primitive's gradient of the signed distance (central differences).

        Args:
            points: (n, 3) or (3,), m, in the object frame.

        Returns:
            Unit normals, the shape of `points`.
        """
        p, single = _check_points(points)
        if self.mesh is not None:
            normal = self._surface.normal(p)
        else:
            closest = _SURFACE_QUERIES[self.shape](p, self.half_sizes)[0]
            step = 1e-6 * np.eye(3)
            query = lambda q: _SURFACE_QUERIES[self.shape](q, self.half_sizes)[1]  # noqa: E731
            gradient = np.column_stack([query(closest + h) - query(closest - h) for h in step])
            normal = gradient / np.linalg.norm(gradient, axis=1, keepdims=True)
        return normal[0] if single else normal

    @cached_property
    def _surface(self) -> MeshQueries:
        """The mesh's query structures (`mesh_queries`), built on first use in a process and kept with the object."""
        if self.mesh is None:
            raise InvalidInput(f"{self.name} is a {self.shape}, not a mesh: it has no mesh surface to query")
        return mesh_queries(self.mesh, self.mesh_digest)

    def __getstate__(self) -> dict:
        """What a worker process gets: the object without its query structures (megabytes; it builds its own)."""
        return {k: v for k, v in self.__dict__.items() if k != "_surface"}


def _check_points(points: object) -> tuple[np.ndarray, bool]:
    given = np.asarray(points, dtype=float)
    single = given.ndim == 1
    p = np.atleast_2d(given)
    if p.ndim != 2 or p.shape[1] != 3 or not np.all(np.isfinite(p)):
        raise InvalidInput(f"points must be finite with shape (n, 3) or (3,), got shape {given.shape}")
    return p, single


def _box_query(p: np.ndarray, half: tuple[float, ...]) -> tuple[np.ndarray, np.ndarray]:
    h = np.asarray(half)
    clamped = np.clip(p, -h, h)
    outside_gap = np.linalg.norm(p - clamped, axis=1)
    inside = outside_gap == 0.0
    closest = clamped.copy()
    distance = outside_gap.copy()
    if inside.any():
        q = p[inside]
        face_gap = h - np.abs(q)
        axis = np.argmin(face_gap, axis=1)
        rows = np.arange(len(q))
        snapped = q.copy()
        sign = np.where(q[rows, axis] >= 0.0, 1.0, -1.0)
        snapped[rows, axis] = sign * h[axis]
        closest[inside] = snapped
        distance[inside] = -face_gap[rows, axis]
    return closest, distance


def _radial_directions(xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    rho = np.linalg.norm(xy, axis=1)
    direction = np.zeros_like(xy)
    direction[:, 0] = 1.0  # any direction is closest on the axis itself
    off_axis = rho > 0.0
    direction[off_axis] = xy[off_axis] / rho[off_axis, None]
    return rho, direction


def _cylinder_query(p: np.ndarray, half: tuple[float, ...]) -> tuple[np.ndarray, np.ndarray]:
    radius, half_length = half
    rho, direction = _radial_directions(p[:, :2])
    z = p[:, 2]
    d_side = rho - radius
    d_cap = np.abs(z) - half_length
    outside = (d_side > 0.0) | (d_cap > 0.0)
    closest = np.empty_like(p)
    distance = np.empty(len(p))
    # outside: clamp radially and axially
    closest[:, :2] = direction * np.minimum(rho, radius)[:, None]
    closest[:, 2] = np.clip(z, -half_length, half_length)
    distance[:] = np.hypot(np.maximum(d_side, 0.0), np.maximum(d_cap, 0.0))
    # inside: the nearer of the side wall and the end cap
    to_side = ~outside & (d_side >= d_cap)
    to_cap = ~outside & ~to_side
    closest[to_side, :2] = direction[to_side] * radius
    closest[to_side, 2] = z[to_side]
    distance[to_side] = d_side[to_side]
    closest[to_cap, :2] = p[to_cap, :2]
    closest[to_cap, 2] = np.where(z[to_cap] >= 0.0, half_length, -half_length)
    distance[to_cap] = d_cap[to_cap]
    return closest, distance


def _sphere_query(p: np.ndarray, half: tuple[float, ...]) -> tuple[np.ndarray, np.ndarray]:
    radius = half[0]
    norm = np.linalg.norm(p, axis=1)
    direction = np.zeros_like(p)
    direction[:, 2] = 1.0
    away = norm > 0.0
    direction[away] = p[away] / norm[away, None]
    return direction * radius, norm - radius


_SURFACE_QUERIES = {"box": _box_query, "cylinder": _cylinder_query, "sphere": _sphere_query}


#: the largest friction coefficient an object may have (rubber on rubber is about 1-2; 1e6 once gave epsilon 8054)
MAX_FRICTION = 5.0
#: the shapes of the paper's objects, which are also their names
PAPER_SHAPES = ("box", "cylinder", "sphere")


def _friction(value: object) -> float:
    friction = _positive(value, "friction")
    if friction > MAX_FRICTION:
        raise InvalidInput(f"friction must be at most {MAX_FRICTION:g} (a sliding friction coefficient), got {value!r}")
    return friction


def _positive(value: object, argument: str) -> float:
    try:
        number = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise InvalidInput(f"{argument} must be a positive number, got {value!r}") from None
    if not math.isfinite(number) or number <= 0.0:
        raise InvalidInput(f"{argument} must be a positive finite number, got {value!r}")
    return number


#: the dimensions `make_object` takes by shape (and the mesh's file and scale)
DIMENSIONS: dict[str, tuple[str, ...]] = {"box": ("size",), "cylinder": ("radius", "length"), "sphere": ("radius",),
                                          "mesh": ("mesh", "scale")}


def make_object(shape: str, *, mass: float | None = None, friction: float | None = None, name: str | None = None,
                **dimensions: object) -> GraspObject:
    """Make a box, cylinder, sphere or mesh object, or a variant of one of the paper's objects.

    With only `mass` and `friction`, a variant of the paper's object of that name:
    `make_object("cylinder", friction=0.3)` is `get_object("cylinder").with_(friction=0.3)`, named
    'cylinder_friction0.3'. A mesh must be a watertight solid; it is moved to its centre of mass and turned
    onto its principal axes (long axis z), and a non-convex one is split into convex parts for MuJoCo
    (`meshes.py` says how).

    Args:
        shape: 'box', 'cylinder', 'sphere' or 'mesh'.
        mass: kg (default 0.1).
        friction: the sliding friction coefficient, at most `MAX_FRICTION` (default `DEFAULT_FRICTION`).
        name: the object's name (default: made from the shape and sizes; a mesh file's stem, with `_mesh` added
            where the stem names one of the library's objects: `box.stl` is `box_mesh`, not the paper's box).
        **dimensions: the shape's (`DIMENSIONS`): `radius` (a cylinder's or a sphere's, m), `length` (a
            cylinder's, m), `size` (a box's full x, y, z extents, m); for a mesh `mesh` (a `trimesh.Trimesh`, a
            mesh file (.stl, .obj, .ply, ...) or an object file of a robot data package (.urdf, MJCF .xml:
            `meshes.model_file_mesh`)) and `scale` (metres per unit of the mesh: 0.001 for a file in mm; default 1).

    Returns:
        The object; every extent `MIN_EXTENT` to `MAX_EXTENT` (5 mm to 30 cm).

    Raises:
        ValueError: a missing or extra size for the shape, a size, mass or friction out of range, a mesh
            that is not a graspable closed solid; the message names the argument.
    """
    known = sorted({d for names in DIMENSIONS.values() for d in names})
    unknown = sorted(set(dimensions) - set(known))
    if unknown:
        raise InvalidInput(f"unknown argument(s) {unknown} of make_object; its dimensions are {known}, with mass, "
                           "friction and name")
    given = {k: v for k, v in dimensions.items() if v is not None}
    if shape in PAPER_SHAPES and not given and (mass is not None or friction is not None):
        return get_object(shape).with_(mass=mass, friction=friction, name=name)
    mass = 0.1 if mass is None else mass
    friction = DEFAULT_FRICTION if friction is None else _friction(friction)
    if shape == "mesh":
        extra = [k for k in given if k not in DIMENSIONS["mesh"]]
        if "mesh" not in given:
            raise InvalidInput("a mesh object needs mesh= (a trimesh.Trimesh or a path to a mesh file)")
        if extra:
            raise InvalidInput(f"a mesh takes mesh= and scale=, not {extra}")
        mesh, scale = given["mesh"], given.get("scale", 1.0)
        if not isinstance(mesh, (trimesh.Trimesh, str, os.PathLike)):
            raise InvalidInput(f"mesh must be a trimesh.Trimesh or a path to a mesh file, got {type(mesh).__name__}")
        return _mesh_object(mesh, _positive(scale, "scale"), mass, friction, name)
    if "mesh" in given or "scale" in given:
        raise InvalidInput(f"mesh= and scale= are for shape 'mesh', not {shape!r}")
    if shape not in DIMENSIONS:
        raise InvalidInput(f"unknown object shape {shape!r}; expected one of {SHAPES}")
    extra = [k for k in given if k not in DIMENSIONS[shape]]
    if extra:
        raise InvalidInput(f"a {shape} takes {DIMENSIONS[shape]}, not {extra}")
    missing = [k for k in DIMENSIONS[shape] if k not in given]
    if missing:
        raise InvalidInput(f"a {shape} needs {missing}")
    half, label = _primitive_half_sizes(shape, given)
    extents = 2 * np.asarray(half)
    if extents.max() > MAX_EXTENT or extents.min() < MIN_EXTENT:
        raise InvalidInput(f"a {shape} of {' x '.join(f'{e * 100:.3g}' for e in extents)} cm is not a one-hand grasp: "
                         f"every extent must be {MIN_EXTENT * 1000:.0f} mm to {MAX_EXTENT * 100:.0f} cm (sizes in m)")
    return GraspObject(name=name or label, shape=shape, half_sizes=half,
                       mass=_positive(mass, "mass"), friction=friction)


def _primitive_half_sizes(shape: str, given: dict[str, object]) -> tuple[tuple[float, ...], str]:
    """A primitive's half sizes (m) and its default name, from its dimensions (checked positive)."""
    if shape == "box":
        extents = tuple(np.asarray(given["size"], dtype=float).ravel())
        if len(extents) != 3:
            raise InvalidInput(f"size must be three extents (x, y, z) in metres, got {given['size']!r}")
        return tuple(_positive(e, "size") / 2.0 for e in extents), "box_{:.3f}x{:.3f}x{:.3f}".format(*extents)
    if shape == "cylinder":
        half: tuple[float, ...] = (_positive(given["radius"], "radius"), _positive(given["length"], "length") / 2.0)
        return half, f"cylinder_r{half[0]:.3f}_l{2 * half[1]:.3f}"
    half = (_positive(given["radius"], "radius"),)
    return half, f"sphere_r{half[0]:.3f}"


def _mesh_object(mesh: trimesh.Trimesh | str | os.PathLike, scale: float, mass: float, friction: float,
                 name: str | None) -> GraspObject:
    """A mesh object: the mesh loaded at its scale, made one watertight solid on its principal axes, in parts."""
    loaded = load_mesh(mesh, scale)
    try:
        solid, parts, digest, repair = object_geometry(loaded)
    except InvalidInput as error:  # what no repair saves, said of the file it came from
        if not isinstance(mesh, (str, os.PathLike)):
            raise
        raise InvalidInput(f"{str(mesh)!r}: {error}") from None
    label = name or (f"mesh_{digest[:8]}" if not isinstance(mesh, (str, os.PathLike)) else Path(mesh).stem
                     + ("_mesh" if Path(mesh).stem in PAPER_SHAPES or Path(mesh).stem in FAMILY else ""))
    if repair:  # said once, where the object is made: every result keys the repaired solid's digest
        warnings.warn(f"mesh object {label!r} made one solid: {repair.lstrip('; ')}", stacklevel=3)
    return GraspObject(name=label, shape="mesh", half_sizes=tuple(np.abs(solid.vertices).max(axis=0).tolist()),
                       mass=_positive(mass, "mass"), friction=_positive(friction, "friction"), mesh=solid,
                       parts=tuple(parts), mesh_digest=digest)


PAPER_OBJECTS: dict[str, GraspObject] = {
    "box": make_object("box", size=(0.04, 0.04, 0.16), name="box"),
    "cylinder": make_object("cylinder", radius=0.03, length=0.16, name="cylinder"),
    "sphere": make_object("sphere", radius=0.03, name="sphere"),
}
"""The paper's three objects (Fig. 1): a 4 x 4 x 16 cm box, a cylinder of 3 cm radius and 16 cm length, a sphere
of 3 cm radius; 0.1 kg, friction 0.6."""


def get_object(obj: str | GraspObject) -> GraspObject:
    """The object itself, the paper's object of that name, or a member of the object family.

    Args:
        obj: a `GraspObject`, or a name: 'box', 'cylinder', 'sphere', or a family member (`family.FAMILY`,
            e.g. "capsule_m", "ring_l", "cylinder_mesh").

    Returns:
        The object.

    Raises:
        ValueError: an unknown name.
    """
    if isinstance(obj, GraspObject):
        return obj
    if isinstance(obj, str) and obj in PAPER_OBJECTS:
        return PAPER_OBJECTS[obj]
    if isinstance(obj, str) and obj in FAMILY:
        return _family_object(obj)
    raise InvalidInput(f"unknown object {obj!r}; expected one of {tuple(PAPER_OBJECTS)}, a family name "
                     f"({', '.join(FAMILY[:3])}, ...; see graspmanifold.sim.family.FAMILY) or an object made by "
                     "make_object()")


def named_object(text: str, scale: float = 1.0) -> GraspObject:
    """The object a command line or a study's list names: a library object by its name (`get_object`), or one's own
    mesh file by its path (anything with a suffix or a folder: `make_object("mesh", mesh=text, scale=scale)`).

    Args:
        text: a name, or the path of a mesh file (.stl, .obj, .ply, ...) or of an object file (.urdf, MJCF .xml).
        scale: metres per unit of a mesh file (0.001 for mm); a named object takes none.

    Returns:
        The object.

    Raises:
        InvalidInput: an unknown name, a scale given for a named object, a mesh that is not a graspable solid.
    """
    if _is_name(text):
        if scale != 1.0:
            raise InvalidInput(f"a scale is for mesh files, not the named object {text!r}")
        return get_object(text)
    return make_object("mesh", mesh=text, scale=scale)


def named_objects(texts: list[str], scale: float = 1.0) -> list[GraspObject]:
    """`named_object` of each: library objects by name, mesh files of one's own times `scale` (which then only the
    files take; given without a file, it is refused).

    Args:
        texts: names and mesh file paths.
        scale: metres per unit of the mesh files.

    Returns:
        The objects, in order.
    """
    if scale != 1.0 and all(_is_name(text) for text in texts):
        raise InvalidInput(f"a scale is for mesh files, and {list(texts)} names none")
    return [named_object(text, 1.0 if _is_name(text) else scale) for text in texts]


def _is_name(text: str) -> bool:
    """A library object's name rather than a file: a name it knows, or a text with no suffix and no folder."""
    return text in PAPER_OBJECTS or text in FAMILY or not (Path(text).suffix or os.sep in text)


@cache
def _family_object(name: str) -> GraspObject:
    return make_object("mesh", mesh=family_mesh(name), name=name)


def object_from_params(params: dict) -> GraspObject:
    """The object a stored result describes by its parameters (`GraspObject.params()`).

    Args:
        params: name, shape, half_sizes, mass, friction (and a mesh's digest), as `params()` wrote them.

    Returns:
        The paper's or the family's object of that name where the parameters match it, else the primitive
        made again, or, for a mesh whose file a result does not store, a description without the mesh
        (its name, sizes, mass, friction and digest; it cannot be simulated).

    Raises:
        ValueError: the parameters name no shape or sizes.
    """
    try:
        name, shape, half = str(params["name"]), str(params["shape"]), tuple(float(h) for h in params["half_sizes"])
        mass, friction = float(params["mass"]), float(params["friction"])
    except (KeyError, TypeError, ValueError) as error:
        raise InvalidInput(f"object parameters must give name, shape, half_sizes, mass and friction, got {params!r} "
                         f"({error})") from None
    try:
        known = get_object(name)
        if known.params() == params:
            return known
    except ValueError:
        pass
    return GraspObject(name=name, shape=shape, half_sizes=half, mass=mass, friction=friction,
                       mesh_digest=str(params.get("mesh_digest", "")))
