"""What an object file of a robot package names, read before MuJoCo sees it (round seven's hardening, issue 88).

MuJoCo opens every file an MJCF or URDF file names (`<include>`, mesh, texture, height-field and skin files) and
builds whatever the file describes, `<replicate>` copies included; a file that names a FIFO hangs it for ever, and
300 bytes of nested `<replicate>` build 64,000 geoms for minutes. `object_file_references` parses the file itself
(Python's expat, no entity declared in it allowed), follows its includes, and checks every file it names: a regular
file, readable, within `MAX_REFERENCED_BYTES`, inside a folder where one is given (a dataset folder read as itself);
and it counts the bodies and geoms the file would build, `<replicate>` counts multiplied, against `MAX_BODIES` and
`MAX_GEOMS`. The files it returns are the object's own: `studies.dataset` tells an object's parts from objects of
their own by them (parsed, not searched for as text).

Paths resolve as MuJoCo resolves them: relative to the main file's folder, a mesh's and a skin's under the
compiler's `meshdir` (a texture's under `texturedir`; `assetdir` sets both), a URDF's mesh likewise (by its file name
alone where the compiler says `strippath`). A `package://` URL names a ROS package folder MuJoCo does not know: it is
refused with that reason, not read as a path.
"""

from __future__ import annotations

import os
import xml.etree.ElementTree as ElementTree
from dataclasses import dataclass
from pathlib import Path
from xml.parsers import expat

from ..base.errors import InvalidInput
from ..base.validation import check_input_file

#: bytes an object file, or a file it names, may have (a scan's mesh of 200,000 triangles is about 10 MB)
MAX_REFERENCED_BYTES = 200_000_000
#: bodies and geoms an object file may build, `<replicate>` copies counted (a scanned object's 32 hulls, with room)
MAX_BODIES = 200
MAX_GEOMS = 1_000
#: includes within includes at most (a file that includes itself is refused sooner)
MAX_INCLUDE_DEPTH = 8
#: the attributes of an MJCF element that name a file, by element: and the compiler folder each resolves under
_MJCF_FILES = {"mesh": "meshdir", "skin": "meshdir", "hfield": "meshdir", "texture": "texturedir"}
_TEXTURE_SIDES = ("file", "fileright", "fileleft", "fileup", "filedown", "filefront", "fileback")


@dataclass(frozen=True)
class ObjectFileContents:
    """What an object file names and would build.

    Attributes:
        files: the files it names (its includes, meshes, textures, ...), resolved, each checked, in order.
        bodies: the bodies it would build, `<replicate>` copies counted.
        geoms: the geoms it would build, likewise.
    """

    files: tuple[Path, ...]
    bodies: int
    geoms: int


def _parse(path: Path) -> ElementTree.Element:
    """An XML file parsed without entities: an object file declares none (MuJoCo would not expand them)."""
    with open(path, "rb") as handle:
        data = handle.read(MAX_REFERENCED_BYTES + 1)
    checker = expat.ParserCreate()

    def refuse_entity(*_: object) -> None:
        raise InvalidInput(f"object file {str(path)!r} declares an XML entity: an object file needs none, and none is "
                           "expanded")

    checker.EntityDeclHandler = refuse_entity
    try:
        checker.Parse(data, True)
        return ElementTree.fromstring(data)
    except (ElementTree.ParseError, expat.ExpatError) as error:
        raise InvalidInput(f"object file {str(path)!r} is not well-formed XML: {error}") from None


def _checked(file: Path, what: str, within: Path | None) -> Path:
    """A file an object file names, checked before anything reads it."""
    if within is not None:  # a dataset folder is read as itself: its links too
        inside = within.resolve()
        if not Path(os.path.abspath(file)).is_relative_to(inside) or not file.resolve().is_relative_to(inside):
            raise InvalidInput(f"{what} {str(file)!r} lies outside the folder {str(within)!r}: nothing outside it is "
                               "read unless asked for (`graspmanifold dataset --outside`)")
    resolved = check_input_file(file, what)
    size = resolved.stat().st_size
    if size > MAX_REFERENCED_BYTES:
        raise InvalidInput(f"{what} {str(file)!r} has {size:,} bytes; at most {MAX_REFERENCED_BYTES:,} are read")
    if not os.access(resolved, os.R_OK):
        raise InvalidInput(f"{what} {str(file)!r} cannot be read (no permission)")
    return resolved


def _count(element: ElementTree.Element, copies: int, counts: list[int]) -> None:
    """Add the bodies and geoms under an element, each `copies` times, `<replicate count>` multiplying inside."""
    for child in element:
        times = copies
        if child.tag == "replicate":
            try:
                times = copies * max(0, int(child.get("count", "1")))
            except ValueError:
                raise InvalidInput(f"a <replicate> count must be a whole number, got {child.get('count')!r}") from None
        elif child.tag == "body":
            counts[0] += copies
        elif child.tag == "geom":
            counts[1] += copies
        if counts[0] > MAX_BODIES or counts[1] > MAX_GEOMS:
            raise InvalidInput(f"the object file would build more than {MAX_BODIES} bodies or {MAX_GEOMS} geoms "
                               f"(<replicate> copies counted): at least {counts[0]:,} bodies and {counts[1]:,} geoms; "
                               "an object to grasp has a few dozen")
        _count(child, times, counts)


def _references(root: ElementTree.Element, base: Path, urdf: bool) -> list[tuple[Path, str]]:
    """The files one parsed file names, resolved (its includes among them), with what each is."""
    compiler = {k: v for element in root.iter("compiler") for k, v in element.attrib.items()}
    assets = compiler.get("assetdir", "")
    folders = {"meshdir": compiler.get("meshdir", assets), "texturedir": compiler.get("texturedir", assets)}
    named: list[tuple[Path, str]] = []
    for element in root.iter():
        if urdf and element.tag == "mesh" and "filename" in element.attrib:
            name = element.attrib["filename"]
            if name.startswith("package://"):
                raise InvalidInput(f"the mesh {name!r} names a ROS package (package://), which MuJoCo cannot find: "
                                   "copy the mesh beside the URDF (or into its meshdir) and name it by its file name")
            strip = compiler.get("strippath", "false").lower() == "true"
            named.append((base / folders["meshdir"] / (Path(name).name if strip else name), "mesh file"))
        elif element.tag == "include" and "file" in element.attrib:
            named.append((base / element.attrib["file"], "included file"))
        elif element.tag in _MJCF_FILES:
            folder = folders[_MJCF_FILES[element.tag]]
            for attribute in _TEXTURE_SIDES if element.tag == "texture" else ("file",):
                if attribute in element.attrib:
                    named.append((base / folder / element.attrib[attribute], f"{element.tag} file"))
    return named


def object_file_references(path: str | os.PathLike, within: str | os.PathLike | None = None) -> ObjectFileContents:
    """Every file an object file (MJCF .xml or URDF) names, checked, and what it would build, counted, before MuJoCo
    opens anything (the module doc).

    Args:
        path: the object file.
        within: a folder every file must lie in (links resolved), or None: anywhere.

    Returns:
        The `ObjectFileContents`.

    Raises:
        InvalidInput: a file named that is not a regular readable file within the limits (a FIFO, a device, a
            folder, too large, outside `within`), a ROS package URL, an XML entity, a file that is not XML, or more
            bodies or geoms than `MAX_BODIES` / `MAX_GEOMS`.
    """
    try:
        return _contents(Path(path), None if within is None else Path(within))
    except InvalidInput as error:  # a missing file too (MissingFile is one): named with the object file naming it
        if str(path) in str(error):
            raise
        raise InvalidInput(f"object file {str(path)!r}: {error}") from None


def _contents(main: Path, folder: Path | None) -> ObjectFileContents:
    """`object_file_references` of a path."""
    files: list[Path] = []
    counts = [0, 0]
    pending = [(_checked(main, "object file", folder), 0)]
    seen: set[Path] = set()
    base = main.parent
    while pending:
        file, depth = pending.pop(0)
        if file in seen or depth > MAX_INCLUDE_DEPTH:
            raise InvalidInput(f"object file {str(main)!r}: {str(file)!r} is included twice (or in a loop), or "
                               f"includes nest deeper than {MAX_INCLUDE_DEPTH}")
        seen.add(file)
        root = _parse(file)
        _count(root, 1, counts)
        for named, what in _references(root, base, main.suffix.lower() == ".urdf"):
            checked = _checked(named, what, folder)
            files.append(checked)
            if what == "included file":
                pending.append((checked, depth + 1))
    return ObjectFileContents(tuple(dict.fromkeys(files)), *counts)
