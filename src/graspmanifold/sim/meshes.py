"""Meshes for grasp objects, through trimesh: loading, checks, the object frame, and convex parts.

A mesh object must be a closed solid a hand can hold: watertight, with a positive volume, between
`MIN_EXTENT` and `MAX_EXTENT` across (a file in millimetres needs `scale=0.001`). Meshes as datasets ship them are
made one first (`make_solid`: holes filled, overlapping pieces joined). It is put into
the library's object frame (`object_frame`): the centre of mass at the origin and the axes along
the principal axes of inertia, ordered by the mesh's extent along them, so that z is the longest
axis (the long axis, as for the paper's box and cylinder) and x the shortest; each axis points to
the side where the mesh reaches further (third moment of the vertices >= 0), so the frame does not
depend on how the file was written.

MuJoCo collides a mesh geom as its convex hull. A convex mesh is one geom; a non-convex one (a
ring handle, a mug) is split into nearly convex parts by V-HACD (`trimesh.decomposition`, through
the `vhacdx` package), run single-threaded with fixed parameters so the parts are the same on every
run (`convex_parts`); a convex decomposition given as pieces (as grasp datasets ship objects) keeps its pieces
(`object_geometry`). The closest-point, signed-distance and normal queries use the mesh itself, not its parts.
"""

from __future__ import annotations

import hashlib
import os
import warnings
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import trimesh
from scipy.sparse.csgraph import minimum_spanning_tree
from scipy.spatial.transform import Rotation

from ..base.errors import InvalidInput
from ..base.validation import check_input_file
from .mesh_queries import MeshQueries
from .object_files import object_file_references

if TYPE_CHECKING:
    import mujoco

MIN_EXTENT = 0.005  # m: smaller than this is below what the fingertips can resolve
MAX_EXTENT = 0.30  # m: larger than this is not a one-hand grasp (and usually a unit error)
#: triangles a mesh may have: its queries (signed distance, closest point) slow down with them, and MuJoCo
#: collides convex parts of at most 64 vertices
MAX_FACES = 200_000
#: the largest scale an object file may give a mesh: far beyond any change of units a grasp object's file needs
MAX_MESH_SCALE = 1e3
#: the most separate pieces a mesh may have (`make_solid`): a convex decomposition has tens; 1,000 pieces took 60 s
#: and 3.8 GB before a MemoryError
MAX_PIECES = 256
#: the file formats a mesh object is read from (trimesh's meshes; not its archives)
MESH_FORMATS = ("stl", "obj", "ply", "off", "glb", "gltf")
#: the object files of robot data packages a mesh object is read from, by MuJoCo (`model_file_mesh`)
MODEL_FORMATS = ("urdf", "xml")
#: m: closed pieces at most this far apart are one object (a convex decomposition's hulls leave gaps of up to
#: about half a millimetre between them; a hand's contact cannot tell them apart)
PIECE_GAP = 0.001

#: V-HACD settings: enough parts for a handle or a mug, deterministic (single-threaded)
DECOMPOSITION = {"maxConvexHulls": 16, "resolution": 100_000, "maxNumVerticesPerCH": 64, "asyncACD": False}


def _joined(pieces: list[trimesh.Trimesh]) -> trimesh.Trimesh:
    """Meshes as one mesh (`trimesh.util.concatenate`: their vertices and faces side by side, nothing merged).

    Args:
        pieces: one or more meshes.

    Returns:
        The one mesh.
    """
    mesh = trimesh.util.concatenate(pieces)
    assert isinstance(mesh, trimesh.Trimesh)  # meshes in, a mesh out
    return mesh


def model_file_mesh(path: Path) -> trimesh.Trimesh:
    """The geometry an object file of a robot data package names, as one mesh: a URDF or an MJCF file compiled by
    MuJoCo (its mesh files found as MuJoCo finds them), every geom of it (meshes and primitives) where it lies at
    the model's reference pose, its pieces kept apart (`make_solid` joins them, or keeps a convex decomposition).
    Every file it names is checked, and what it would build counted, before MuJoCo opens anything
    (`object_files.object_file_references`).

    Args:
        path: the .urdf or .xml file (the files it names may lie anywhere: a dataset folder's are checked to lie
            in it by `studies.dataset`).

    Returns:
        The pieces, in the file's units and frame.

    Raises:
        InvalidInput: a file MuJoCo cannot compile, one with no geometry, or one `object_file_references` refuses.
    """
    import mujoco

    object_file_references(path)
    try:
        spec = mujoco.MjSpec.from_file(str(path))
        # only the geometry is read: the file's masses and inertias (often placeholders) are not
        spec.compiler.inertiafromgeom = mujoco.mjtInertiaFromGeom.mjINERTIAFROMGEOM_TRUE
        for body in spec.bodies:
            body.explicitinertial, body.fullinertia = False, np.full(6, np.nan)
        model = spec.compile()
    except Exception as error:  # MuJoCo raises ValueError for a file it cannot compile, with its reason
        raise InvalidInput(f"object file {str(path)!r} could not be compiled by MuJoCo: {error}") from None
    moving = [model.joint(j).name or f"joint {j}" for j in range(model.njnt)
              if model.jnt_type[j] != mujoco.mjtJoint.mjJNT_FREE]
    if moving:  # an articulated object (a drawer, scissors) is not one of the library's rigid objects
        warnings.warn(f"object file {path.name!r} has {len(moving)} joint{'s' * (len(moving) > 1)} "
                      f"({', '.join(moving[:5])}{', ...' if len(moving) > 5 else ''}), fixed at the reference pose: "
                      "the object is one rigid solid", stacklevel=2)
    scales = np.abs(model.mesh_scale)
    if model.nmesh and not (np.isfinite(scales).all() and scales.min() > 0 and scales.max() <= MAX_MESH_SCALE):
        with np.errstate(divide="ignore", invalid="ignore"):  # a scale of 0 is the farthest from 1
            worst = model.mesh_scale[int(np.argmax(np.nan_to_num(np.abs(np.log(scales)), nan=np.inf).max(axis=1)))]
        raise InvalidInput(f"object file {str(path)!r} scales a mesh by {worst.tolist()}: each scale must be a finite "
                           f"number, not 0, of magnitude at most {MAX_MESH_SCALE:g}")
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    pieces = []
    for geom in range(model.ngeom):
        kind, size = model.geom_type[geom], model.geom_size[geom]
        if kind == mujoco.mjtGeom.mjGEOM_MESH:
            piece = _mesh_file_piece(model, int(model.geom_dataid[geom]), path.parent / spec.compiler.meshdir)
        elif kind == mujoco.mjtGeom.mjGEOM_BOX:
            piece = trimesh.creation.box(extents=2 * size)
        elif kind == mujoco.mjtGeom.mjGEOM_SPHERE:
            piece = trimesh.creation.icosphere(subdivisions=3, radius=size[0])
        elif kind == mujoco.mjtGeom.mjGEOM_CYLINDER:
            piece = trimesh.creation.cylinder(radius=size[0], height=2 * size[1], sections=48)
        elif kind == mujoco.mjtGeom.mjGEOM_CAPSULE:
            piece = trimesh.creation.capsule(height=2 * size[1], radius=size[0], count=[24, 24])
        elif kind == mujoco.mjtGeom.mjGEOM_ELLIPSOID:
            piece = trimesh.creation.icosphere(subdivisions=3, radius=1.0)
            piece.apply_scale(size)
        else:  # a plane, a height field: not part of an object
            continue
        transform = np.eye(4)
        transform[:3, :3] = data.geom_xmat[geom].reshape(3, 3)
        transform[:3, 3] = data.geom_xpos[geom]
        piece.apply_transform(transform)
        pieces.append(piece)
    if not pieces:
        raise InvalidInput(f"object file {str(path)!r} names no geometry (no mesh, box, sphere, cylinder, capsule "
                           "or ellipsoid geom)")
    return _joined(pieces)


def _mesh_file_piece(model: mujoco.MjModel, mesh_id: int, folder: Path) -> trimesh.Trimesh:
    """A mesh geom's mesh read from its file by trimesh (every object of an .obj: MuJoCo's own reader keeps the
    faces of the first), scaled as the model scales it, and placed as MuJoCo's compiled mesh is in its geom's frame
    (MuJoCo moves a mesh's vertices into its inertial frame, `mesh_pos` and `mesh_quat`)."""
    name = model.paths[model.mesh_pathadr[mesh_id]:].split(b"\x00", 1)[0].decode()
    file = folder / name
    piece = read_mesh_file(check_input_file(file, "mesh file named by an object file"))
    turn = Rotation.from_quat(model.mesh_quat[mesh_id], scalar_first=True).as_matrix()
    piece.vertices = (np.asarray(piece.vertices) * model.mesh_scale[mesh_id] - model.mesh_pos[mesh_id]) @ turn
    return piece


#: the first bytes of files that are often renamed by mistake, and what they are
_NOT_MESHES = {b"\x89PNG": "a PNG image", b"\xff\xd8\xff": "a JPEG image", b"GIF8": "a GIF image",
               b"%PDF": "a PDF document", b"PK\x03\x04": "a zip archive", b"\x1f\x8b": "a gzip archive",
               b"\x93NUMPY": "a NumPy array file"}
#: the mesh formats that are text (a NUL byte in one is not that format)
_TEXT_FORMATS = ("obj", "off", "gltf")


def check_mesh_bytes(path: Path) -> None:
    """Refuse a file that cannot be the mesh its suffix says, before a parser meets it: an image or an archive
    renamed (a PNG renamed .obj reached trimesh's text decoder, and a machine without charset_normalizer answered
    "No module named 'charset_normalizer'"), a text format with binary bytes, a binary STL whose triangle count does
    not fit its size (2^32 - 1 triangles in 134 bytes).

    Args:
        path: the mesh file (`MESH_FORMATS`).

    Raises:
        InvalidInput: what the file is instead, or how it is broken.
    """
    size = path.stat().st_size
    with open(path, "rb") as handle:
        head = handle.read(4096)
    suffix = path.suffix.lower().lstrip(".")
    for magic, what in _NOT_MESHES.items():
        if head.startswith(magic):
            raise InvalidInput(f"mesh file {str(path)!r} is {what}, not a .{suffix} mesh")
    if suffix in _TEXT_FORMATS and b"\0" in head:
        raise InvalidInput(f"mesh file {str(path)!r} holds binary bytes; a .{suffix} mesh is text")
    binary = not head.lstrip().startswith(b"solid") or b"\0" in head  # a binary header may begin "solid" too
    if suffix == "stl" and binary and size >= 84:
        declared = int.from_bytes(head[80:84], "little")
        if 84 + 50 * declared != size:
            raise InvalidInput(f"mesh file {str(path)!r}: a binary STL of {declared} triangles has {84 + 50 * declared} "
                               f"bytes, this one {size}; the file is truncated or not an STL")


def read_mesh_file(path: Path) -> trimesh.Trimesh:
    """A mesh file's triangles, its objects (an .obj's `o` groups, a glTF's nodes) kept apart: each object's
    duplicate vertices merged, but not one object's with another's, so that the pieces of a convex decomposition
    that touch along their cuts stay pieces (`make_solid`).

    Args:
        path: the file (`MESH_FORMATS`).

    Returns:
        The mesh, in the file's units.

    Raises:
        InvalidInput: a file that cannot be read, holds no triangles or too many, or has non-finite vertices.
    """
    check_mesh_bytes(path)
    try:  # unprocessed first: processing would drop non-finite vertices and leave holes to blame
        loaded = trimesh.load(path, process=False, split_object=True, group_material=False)
    except ImportError as error:  # a text format trimesh decodes with an optional package
        raise InvalidInput(f"mesh file {str(path)!r} could not be read: trimesh needs the package "
                           f"{error.name or error} for it (pip install {error.name or 'it'})") from None
    except Exception as error:  # trimesh raises many kinds for a file it cannot parse
        raise InvalidInput(f"mesh file {str(path)!r} could not be read as a mesh: {error}") from None
    found = list(loaded.dump()) if isinstance(loaded, trimesh.Scene) else [loaded]
    pieces = [p for p in found if isinstance(p, trimesh.Trimesh) and len(p.faces)]
    faces = sum(len(p.faces) for p in pieces)
    if not faces:
        raise InvalidInput(f"mesh file {str(path)!r} holds no triangles")
    if faces > MAX_FACES:
        raise InvalidInput(f"mesh file {str(path)!r} has {faces} triangles, more than {MAX_FACES}: a grasp object "
                           "needs far fewer (its collision parts keep at most 64 vertices each); simplify it first, "
                           "e.g. mesh.simplify_quadric_decimation(face_count=20000)")
    for piece in pieces:
        bad = np.flatnonzero(~np.isfinite(piece.vertices).all(axis=1))
        if len(bad):
            raise InvalidInput(f"mesh file {str(path)!r} has {len(bad)} vertices with non-finite coordinates (NaN or "
                               f"inf), the first at index {bad[0]}")
        piece.process()
    return _joined(pieces) if len(pieces) > 1 else pieces[0]


def load_mesh(mesh: trimesh.Trimesh | str | os.PathLike, scale: float = 1.0) -> trimesh.Trimesh:
    """A copy of `mesh` (a trimesh, a path to a .stl/.obj/.ply/... file, or an object file, .urdf or MJCF .xml,
    that names its mesh pieces: `model_file_mesh`), scaled by `scale`."""
    if isinstance(mesh, (str, os.PathLike)) and Path(mesh).suffix.lower().lstrip(".") in MODEL_FORMATS:
        mesh = model_file_mesh(check_input_file(mesh, "object file"))
    if isinstance(mesh, (str, os.PathLike)):
        path = check_input_file(mesh, "mesh file")
        if path.suffix.lower().lstrip(".") not in MESH_FORMATS:
            raise InvalidInput(f"mesh file {str(mesh)!r}: {path.suffix or 'no suffix'} is not a mesh format the library "
                               f"reads ({', '.join('.' + f for f in MESH_FORMATS + MODEL_FORMATS)})")
        mesh = read_mesh_file(path)
    elif not isinstance(mesh, trimesh.Trimesh):
        raise InvalidInput(f"mesh must be a trimesh.Trimesh or a path to a mesh file, got {type(mesh).__name__}")
    try:
        scale = float(scale)
    except (TypeError, ValueError):
        raise InvalidInput(f"scale must be a positive finite number, got {scale!r}") from None
    if not np.isfinite(scale) or scale <= 0:
        raise InvalidInput(f"scale must be a positive finite number, got {scale!r}")
    mesh = mesh.copy()
    mesh.apply_scale(scale)
    return mesh


def make_solid(mesh: trimesh.Trimesh) -> tuple[trimesh.Trimesh, str]:
    """The mesh made one closed solid, as object meshes come in the field (scans with holes, objects of several
    overlapping pieces, convex decompositions), by a stated and deterministic repair:

    - each open piece's holes are filled (`trimesh.repair.fill_holes`, fans over each boundary loop: networkx finds
      the loops), its normals made consistent;
    - several closed pieces become their union (`trimesh.boolean.union` with manifold3d, exact and robust); pieces
      their union leaves apart by at most `PIECE_GAP` (a convex decomposition's hulls) stay one object.

    A mesh that is already one closed solid is returned as it is. What no repair can make one solid (a piece whose
    holes stay open, pieces that do not touch) is left for `check_solid` to refuse with its reason.

    Args:
        mesh: a mesh (not changed).

    Returns:
        (the mesh, or a repaired copy; what was done, '' when nothing).
    """
    if not isinstance(mesh, trimesh.Trimesh):
        raise InvalidInput(f"make_solid takes a trimesh.Trimesh, got {type(mesh).__name__}")
    if mesh.is_watertight and int(mesh.body_count) == 1:
        return mesh, ""
    if int(mesh.body_count) > MAX_PIECES:
        raise InvalidInput(f"the mesh has {int(mesh.body_count)} separate pieces, more than {MAX_PIECES}: a grasp "
                           "object's convex decomposition needs far fewer (joining them measures every pair's gap)")
    pieces = mesh.split(only_watertight=False) if int(mesh.body_count) > 1 else [mesh.copy()]
    done, filled = [], 0
    for piece in pieces:
        if not piece.is_watertight:
            piece = piece.copy()
            trimesh.repair.fill_holes(piece, use_fan=True)
            trimesh.repair.fix_normals(piece)
            filled += int(piece.is_watertight)
        done.append(piece)
    what = [f"the holes of {filled} open piece{'s' * (filled != 1)} filled"] if filled else []
    done, cavities = _cavities_filled(done)
    if cavities:
        what.append(f"the sealed cavit{'ies' if cavities > 1 else 'y'} of {cavities} inner shell{'s' * (cavities > 1)} "
                    "filled (a hollow solid's outside kept)")
        if len(done) == 1:
            return done[0], "; ".join(what)
    closed = [piece for piece in done if piece.is_watertight and piece.is_volume]
    if len(done) > 1 and len(closed) == len(done):  # on a 0.1 um grid first: pieces that touch (a decomposition's,
        snapped = [trimesh.Trimesh(np.round(piece.vertices, 7), piece.faces, process=False) for piece in closed]
        joined = trimesh.boolean.union(snapped, engine="manifold")  # float32 in a model file) do not stay apart
        solid = joined.is_watertight and joined.volume > 0
        if solid and int(joined.body_count) == 1:
            return joined, "; ".join(what + [f"the union of {len(done)} closed pieces (manifold3d)"])
        if solid and (gap := piece_gap(joined.split())) <= PIECE_GAP:
            return joined, "; ".join(what + [f"the union of {len(done)} closed pieces (manifold3d), "
                                             f"{int(joined.body_count)} solids at most {gap * 1000:.2g} mm apart kept "
                                             "as one object"])
    if len(done) == 1:
        return done[0], "; ".join(what)
    return mesh, ""


def _cavities_filled(pieces: list[trimesh.Trimesh]) -> tuple[list[trimesh.Trimesh], int]:
    """The pieces without the inner shells of sealed cavities (a closed piece facing inwards, within another's
    bounds: a hollow solid's inside wall, which `check_solid` would call a separate solid), and how many went."""
    kept = []
    for piece in pieces:
        inward = piece.is_watertight and float(piece.volume) < 0
        inside = any(other is not piece and np.all(other.bounds[0] <= piece.bounds[0])
                     and np.all(piece.bounds[1] <= other.bounds[1]) for other in pieces)
        if not (inward and inside):
            kept.append(piece)
    return kept, len(pieces) - len(kept)


def piece_gap(pieces: list[trimesh.Trimesh]) -> float:
    """The largest gap (m) that joins closed pieces into one group: the longest edge of the minimum spanning tree of
    their distances (each pair's: the nearest of one's vertices to the other's surface, both ways).

    Args:
        pieces: closed meshes.

    Returns:
        The gap (0 for one piece).
    """
    queries = [MeshQueries(piece) for piece in pieces]
    apart = np.zeros((len(pieces), len(pieces)))
    for i, j in zip(*np.triu_indices(len(pieces), 1)):
        nearest = min(np.abs(queries[j].signed_distance(pieces[i].vertices)).min(),
                      np.abs(queries[i].signed_distance(pieces[j].vertices)).min())
        apart[i, j] = max(float(nearest), 1e-300)  # touching pieces: an edge of (almost) no length
    return float(minimum_spanning_tree(apart).max()) if len(pieces) > 1 else 0.0


def check_solid(mesh: trimesh.Trimesh) -> None:
    """Raise ValueError unless the mesh is a closed solid of a graspable size."""
    if len(mesh.faces) == 0 or not np.all(np.isfinite(mesh.vertices)):
        raise InvalidInput("mesh has no triangles or non-finite vertices")
    if len(mesh.faces) > MAX_FACES:
        raise InvalidInput(f"mesh has {len(mesh.faces)} triangles, more than {MAX_FACES}: simplify it first, e.g. "
                           "mesh.simplify_quadric_decimation(face_count=20000)")
    if not mesh.is_watertight:
        raise InvalidInput("mesh is not watertight (it has holes or open edges that filling each boundary loop "
                           "does not close, `make_solid`): a grasp object must be a closed solid")
    with np.errstate(invalid="ignore", divide="ignore"):  # a flat mesh divides by its zero volume
        solid = bool(mesh.is_volume) and float(mesh.volume) > 0
    if not solid:
        raise InvalidInput(f"mesh encloses no positive volume (volume {mesh.volume:.3g} m^3): it is flat, "
                         "inside out or self-intersecting")
    bodies = int(mesh.body_count)
    if bodies > 1 and (gap := piece_gap(mesh.split(only_watertight=False))) > PIECE_GAP:
        raise InvalidInput(f"mesh holds {bodies} separate solids that do not touch (their union, `make_solid`, "
                           f"leaves them {gap * 1000:.3g} mm apart, more than the {PIECE_GAP * 1000:g} mm a "
                           "decomposition's pieces may be): a grasp object is one solid; take one of mesh.split()")
    extent = float(mesh.extents.max())
    if extent > MAX_EXTENT:
        raise InvalidInput(f"mesh is {extent:.2f} m across; a hand grasps objects of at most {MAX_EXTENT:.2f} m "
                         "(a file in millimetres needs scale=0.001)")
    if float(mesh.extents.min()) < MIN_EXTENT:
        raise InvalidInput(f"mesh is only {mesh.extents.min() * 1000:.3g} mm thick; a grasp object needs at least "
                         f"{MIN_EXTENT * 1000:.0f} mm in every direction")


def canonical_order(mesh: trimesh.Trimesh) -> trimesh.Trimesh:
    """The same solid with its vertices in lexicographic order and its faces sorted, each listed from its
    lowest vertex on (its orientation kept): a mesh library that lists them in another order (trimesh 5 does,
    against 4) gives the same arrays, so the same object frame, convex parts and digest.

    A mesh of several solids (a decomposition's, at most `PIECE_GAP` apart) is ordered solid by solid, the solids by
    their first vertex, so that two that touch at a point or an edge are not welded into one non-manifold surface.

    Args:
        mesh: a mesh.

    Returns:
        A new mesh (duplicate vertices merged within each solid, but where a solid touches itself).
    """
    if int(mesh.body_count) > 1:
        solids = sorted((canonical_order(body) for body in mesh.split(only_watertight=False)),
                        key=lambda body: tuple(body.vertices[0]))
        return _joined(solids)
    points = np.asarray(mesh.vertices, dtype=float) + 0.0
    vertices, inverse = np.unique(points, axis=0, return_inverse=True)
    ordered = _sorted_faces(vertices, inverse.reshape(-1)[np.asarray(mesh.faces)])
    if ordered.is_watertight or not mesh.is_watertight:
        return ordered
    # a solid that touches itself at a point or an edge keeps two vertices there: merged, it would not be closed
    order = np.lexsort(points.T[::-1])
    rank = np.empty(len(order), dtype=np.intp)
    rank[order] = np.arange(len(order))
    return _sorted_faces(points[order], rank[np.asarray(mesh.faces)])


def _sorted_faces(vertices: np.ndarray, faces: np.ndarray) -> trimesh.Trimesh:
    """A mesh of these vertices and faces, each face listed from its lowest vertex on, the faces sorted."""
    first = np.argmin(faces, axis=1)
    faces = np.take_along_axis(faces, (first[:, None] + np.arange(3)) % 3, axis=1)
    return trimesh.Trimesh(vertices, faces[np.lexsort(faces.T[::-1])], process=False)


def object_geometry(mesh: trimesh.Trimesh) -> tuple[trimesh.Trimesh, list[trimesh.Trimesh], str, str]:
    """An object's geometry from a mesh as given: the mesh made solid (`make_solid`), checked, in the object frame
    (see the module docstring; its vertices and faces in `canonical_order`), and its convex parts for MuJoCo: a
    convex decomposition given as pieces (several closed convex pieces) is used as given, moved into the same frame;
    else the solid itself when convex, or its V-HACD parts (`convex_parts`).

    Args:
        mesh: the mesh (not changed).

    Returns:
        (the solid, its convex parts, its digest (`mesh_digest` of the solid, and of the parts where they were
        given), what was done to make it solid ('' when nothing)).
    """
    made, repair = make_solid(mesh)
    check_solid(made)
    solid = canonical_order(made)
    centre = solid.center_mass
    solid.apply_translation(-centre)
    axes = np.asarray(solid.principal_inertia_vectors, dtype=float)  # rows
    along = solid.vertices @ axes.T
    axes = axes[np.argsort(np.ptp(along, axis=0), kind="stable")]  # shortest extent first, longest last
    along = solid.vertices @ axes.T
    axes *= np.where(np.sum(along ** 3, axis=0) >= 0.0, 1.0, -1.0)[:, None]
    if np.linalg.det(axes) < 0:
        axes[0] *= -1.0
    rotation = np.eye(4)
    rotation[:3, :3] = axes
    solid.apply_transform(rotation)
    check_solid(solid)
    pieces = mesh.split(only_watertight=False) if int(mesh.body_count) > 1 else []
    if pieces and all(piece.is_watertight and piece.is_convex and piece.volume > 0 for piece in pieces):  # a decomposition
        parts = [canonical_order(piece) for piece in pieces]
        for part in parts:  # the same two steps as the solid's
            part.apply_translation(-centre)
            part.apply_transform(rotation)
        repair += f"; its {len(parts)} convex pieces kept as its collision parts"
        return solid, parts, mesh_digest(solid, parts), repair
    return solid, convex_parts(solid), mesh_digest(solid), repair


def object_frame(mesh: trimesh.Trimesh) -> trimesh.Trimesh:
    """A checked copy of the mesh made solid in the object frame (`object_geometry`'s solid)."""
    return object_geometry(mesh)[0]


def convex_parts(mesh: trimesh.Trimesh) -> list[trimesh.Trimesh]:
    """The mesh itself when convex, else its V-HACD parts (deterministic)."""
    if mesh.is_convex:
        return [mesh]
    try:
        parts = mesh.convex_decomposition(**DECOMPOSITION)
    except ImportError:
        raise ImportError("a non-convex mesh needs a convex decomposition for MuJoCo: pip install vhacdx") from None
    parts = parts if isinstance(parts, list) else [parts]
    return [part if isinstance(part, trimesh.Trimesh) else trimesh.Trimesh(**part) for part in parts]


def mesh_digest(mesh: trimesh.Trimesh, parts: list[trimesh.Trimesh] | tuple = ()) -> str:
    """A short hash of the vertices and faces (and of convex parts given with the mesh): two objects with the same
    digest are the same solid, collided the same way."""
    digest = hashlib.sha256()
    for each in (mesh, *parts):
        digest.update(np.ascontiguousarray(each.vertices, dtype=float).tobytes())
        digest.update(np.ascontiguousarray(each.faces, dtype=np.int64).tobytes())
    return digest.hexdigest()[:16]
