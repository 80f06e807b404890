"""Files: NumPy .npz archives with readable JSON metadata, written atomically, loaded with checks.

Every file the library writes carries `{"schema": ..., "kind": ..., "library_version": ...}` plus
whatever the writer adds (units, seed, parameters). A temporary file is renamed into place only
once it is complete and on disk, so an interrupted write never leaves a half-written file behind;
files get the permissions the user's umask gives.
"""

from __future__ import annotations

import csv
import errno
import hashlib
import json
import os
import tempfile
import time
import zipfile
from collections.abc import Iterable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import IO, Self

import numpy as np

from .errors import InvalidInput, OutputInUse
from .validation import check_input_file
from .version import __version__, code_fingerprint

SCHEMA_VERSION = 2
_METADATA_KEY = "__metadata__"


def library_version() -> str:
    return __version__


def software_versions() -> dict[str, str]:
    """What a result depends on besides its configuration: this library's version and code
    (`version.code_fingerprint`), the versions of MuJoCo, NumPy, SciPy, numba and Python, the BLAS NumPy calls
    (NumPy's and SciPy's: each library, version and the processor kernels it chose) and the machine (processor, cores, system): a run
    records them, so that a result can be traced to the arithmetic that made it (RELIABILITY.md says how far
    results move between machines)."""
    import platform

    import mujoco
    import numba
    import scipy
    from threadpoolctl import threadpool_info

    processor = platform.processor()
    try:  # Linux names the processor model here; platform.processor() is often empty
        processor = next(line.split(":", 1)[1].strip() for line in Path("/proc/cpuinfo").read_text().splitlines()
                         if line.startswith("model name"))
    except (OSError, StopIteration):
        pass
    import scipy.linalg  # noqa: F401  (SciPy's own BLAS, loaded with its linear algebra)

    blas = "; ".join(sorted(f"{Path(b.get('filepath', '?')).parent.name.removesuffix('.libs')}: "
                            f"{b.get('internal_api', '?')} {b.get('version', '?')} ({b.get('architecture', '?')} kernels)"
                            for b in threadpool_info() if b.get("user_api") == "blas")) or "?"  # in one order: the
    # libraries are listed in the order they were loaded, which differs between runs
    return {"graspmanifold": __version__, "code": code_fingerprint(), "mujoco": mujoco.__version__, "numpy": np.__version__,
            "scipy": scipy.__version__, "numba": numba.__version__, "blas": blas,
            "python": platform.python_version(), "machine": f"{platform.machine()} {processor or '?'}, "
            f"{os.cpu_count()} cores, {platform.system()} {platform.release()}"}


def fingerprint(array: np.ndarray) -> str:
    """A short content hash of an array (shape, dtype and values)."""
    a = np.ascontiguousarray(array)
    digest = hashlib.sha256(f"{a.shape}{a.dtype.str}".encode())
    digest.update(a.tobytes())
    return digest.hexdigest()[:16]


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


@contextmanager
def atomic_write(path: str | os.PathLike, mode: str = "wb") -> Iterator[IO]:
    """Open a temporary file beside `path` for writing; on success it is flushed to disk (fsync),
    given the mode the user's umask gives new files, and renamed into place, so readers never see
    half of it; on any error it is removed and `path` is untouched."""
    if mode not in ("w", "wb"):
        raise InvalidInput(f"mode must be 'w' or 'wb', got {mode!r}")
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=TEMPORARY_SUFFIX, dir=path.parent)
    try:
        with os.fdopen(fd, mode, encoding="utf-8" if mode == "w" else None) as handle:
            yield handle
            handle.flush()
            os.fsync(handle.fileno())
        os.chmod(tmp, 0o666 & ~_umask())  # mkstemp makes 0600 files
        os.replace(tmp, path)
    except OSError as error:  # a full disk, a quota, a folder gone: name the file that could not be written
        Path(tmp).unlink(missing_ok=True)
        raise OSError(error.errno, f"cannot write {path}: {error.strerror or error}", str(path)) from error
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


#: the end of every temporary file the library writes (`atomic_write`); nothing else is ever cleaned up
TEMPORARY_SUFFIX = ".graspmanifold.tmp"
#: the lock file that marks an output folder as being written (`output_lock`)
LOCK_FILE = ".graspmanifold.lock"


@contextmanager
def output_lock(lock: str | os.PathLike, output: str | os.PathLike | None = None) -> Iterator[None]:
    """Hold an output for this process while the block runs: a second writer is refused at once.

    The lock is an advisory `flock` on the file `lock`, which the system releases when the holder exits,
    however it ends: a run killed with SIGKILL leaves no stale lock. The lock file is removed when the block
    ends, and so is the lock's folder when this call made it and the block left nothing in it (a run refused
    for a bad argument leaves nothing behind). Where the system has no `flock` (Windows), outputs are not locked.

    Args:
        lock: the lock file, e.g. `out / LOCK_FILE` for a folder.
        output: what the lock guards, for the message (default: the lock's folder).

    Raises:
        OutputInUse: another process holds the lock; the message names it (process id, start time).
        OSError: the lock file cannot be written (a full disk): the message names it.
    """
    try:
        import fcntl
    except ImportError:  # pragma: no cover - not on Linux or macOS
        yield
        return
    lock = Path(lock)
    made = [folder for folder in (lock.parent, *lock.parent.parents) if not folder.exists()]
    while True:  # until the file locked is the one at the path (a holder that ends removes it)
        try:
            lock.parent.mkdir(parents=True, exist_ok=True)
            handle = open(lock, "a+", encoding="utf-8")
        except OSError as error:
            raise OSError(error.errno, f"cannot write {lock}: {error.strerror or error}", str(lock)) from error
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            handle.seek(0)
            holder = handle.read().strip() or "a process"
            handle.close()
            raise OutputInUse(f"{output or lock.parent} is being written by another graspmanifold run ({holder}); "
                              "wait for it to finish, or choose another output") from None
        try:
            if os.stat(lock).st_ino == os.fstat(handle.fileno()).st_ino:
                break
        except FileNotFoundError:
            pass
        handle.close()
    with handle:
        try:
            handle.seek(0)
            handle.truncate()
            handle.write(f"process {os.getpid()}, started {time.strftime('%Y-%m-%d %H:%M:%S')}\n")
            handle.flush()
        except OSError as error:
            raise OSError(error.errno, f"cannot write {lock}: {error.strerror or error}", str(lock)) from error
        try:
            yield
        finally:
            _unlink_if_same(lock, handle.fileno())
            for folder in made:  # innermost first; only folders this call made, and only when empty
                try:
                    folder.rmdir()
                except OSError:
                    break


def _unlink_if_same(path: Path, fd: int) -> None:
    """Remove `path` if it is still the file open as `fd` (not another run's lock made since)."""
    try:
        if os.stat(path).st_ino == os.fstat(fd).st_ino:
            path.unlink()
    except OSError:
        pass


def check_writable_folder(folder: str | os.PathLike, name: str) -> None:
    """Refuse a folder that results cannot be written to, before any work that would be lost if the write failed,
    without making it (a probe file is written in the nearest folder that exists).

    Args:
        folder: where results will go.
        name: the argument that names it, for the message.

    Raises:
        InvalidInput: it is a file, a link that leads nowhere, or it (or the nearest folder that exists) cannot be
            written.
    """
    folder = Path(folder)
    if folder.is_symlink() and not folder.exists():
        raise InvalidInput(f"{name} {folder} is a symbolic link that leads nowhere (a loop, or its target is gone)")
    if folder.exists() and not folder.is_dir():
        raise InvalidInput(f"cannot write results to {folder}: it is a file, not a directory (name another {name})")
    existing = next(f for f in (folder.absolute(), *folder.absolute().parents) if f.exists())
    if not existing.is_dir():
        raise InvalidInput(f"cannot write results to {folder}: {existing} is a file, not a directory")
    try:
        with tempfile.TemporaryFile(dir=existing):
            pass
    except OSError as error:
        raise InvalidInput(f"cannot write results to {folder}: {error.strerror or error}") from None


#: the errors of a write that failed for the machine's reasons, not the program's: a full disk or quota, a
#: read-only file system, no permission, an input/output error
WRITE_FAILURES = (errno.ENOSPC, errno.EDQUOT, errno.EROFS, errno.EACCES, errno.EPERM, errno.EIO)


def write_failure(error: OSError, kept: str) -> str | None:
    """The one line a command ends in when a file could not be written (a full disk), or None for another OSError
    (a bug, which keeps its traceback).

    Args:
        error: the error.
        kept: what is kept and how to resume, said after it.

    Returns:
        'error: No space left on device: <file>; <kept>', or None.
    """
    if error.filename is None and error.errno not in WRITE_FAILURES:
        return None
    said = str(error.strerror or error)
    where = f": {error.filename}" if error.filename is not None and str(error.filename) not in said else ""
    return f"error: {said}{where}; {kept}"


def write_text_atomic(path: str | os.PathLike, text: str) -> Path:
    """Write a text file atomically (see `atomic_write`)."""
    with atomic_write(path, "w") as handle:
        handle.write(text)
    return Path(path)


#: how a number JSON cannot hold is written (standard JSON has no Infinity or NaN), and read back
UNBOUNDED = {"Infinity": float("inf"), "-Infinity": float("-inf"), "NaN": float("nan")}


def _standard(value: object) -> object:
    """`value` with every float JSON cannot hold replaced by its name in `UNBOUNDED`."""
    if isinstance(value, dict):
        return {key: _standard(item) for key, item in value.items()}
    if isinstance(value, (list, tuple, np.ndarray)):
        return [_standard(item) for item in value]
    if isinstance(value, (float, np.floating)) and not np.isfinite(value):
        return "NaN" if np.isnan(value) else ("Infinity" if value > 0 else "-Infinity")
    if isinstance(value, np.generic):
        return _standard(value.item())
    return value


def json_text(value: object, indent: int | None = 1) -> str:
    """Standard JSON for result files, which `JSON.parse` and jq read too.

    Args:
        value: dictionaries, lists (NumPy arrays included), strings, numbers (NumPy scalars included), None.
        indent: as `json.dumps`.

    Returns:
        The text; an infinite or NaN float is written as the string "Infinity", "-Infinity" or "NaN"
        (`read_json` reads it back as the float).
    """
    try:
        return json.dumps(_standard(value), indent=indent, allow_nan=False)
    except TypeError as error:  # a value JSON has no form for (a set, an object)
        raise InvalidInput(f"a result file holds dictionaries, lists, strings, numbers and None: {error}") from None


def _restored(value: object) -> object:
    if isinstance(value, dict):
        return {key: _restored(item) for key, item in value.items()}
    if isinstance(value, list):
        return [_restored(item) for item in value]
    if isinstance(value, str) and value in UNBOUNDED:
        return UNBOUNDED[value]
    return value


def read_json(path: str | os.PathLike, name: str) -> dict:
    """Read a result file `json_text` wrote (or an older one with bare Infinity), unbounded numbers as floats.

    Args:
        path: the file.
        name: what the file is, for the message of a missing or corrupt file.

    Returns:
        Its data.
    """
    raw = check_input_file(path, name).read_bytes()
    try:
        data = json.loads(raw.decode("utf-8"))
    except (json.JSONDecodeError, UnicodeDecodeError, RecursionError) as error:
        raise InvalidInput(f"{name} ({path}) is not JSON: {type(error).__name__}: {str(error)[:200]}") from None
    if not isinstance(data, dict):
        raise InvalidInput(f"{name} ({path}) must hold a JSON object, got {type(data).__name__}")
    restored = _restored(data)
    assert isinstance(restored, dict)
    return restored


def save_npz(path: str | os.PathLike, kind: str, arrays: dict[str, np.ndarray], metadata: dict,
             *, overwrite: bool = True) -> Path:
    """Write arrays and metadata to `path` atomically; refuse an existing file unless `overwrite`."""
    path = Path(path)
    if path.suffix != ".npz":
        raise InvalidInput(f"path must end in .npz, got {str(path)!r}")
    if path.exists() and not overwrite:
        raise FileExistsError(f"{path} exists; pass overwrite=True (or --force) to replace it")
    if _METADATA_KEY in arrays:
        raise InvalidInput(f"{_METADATA_KEY!r} is reserved")
    meta = {"schema": SCHEMA_VERSION, "kind": kind, "library_version": library_version(), **metadata}
    with atomic_write(path, "wb") as handle:
        write_npz(handle, {**arrays, _METADATA_KEY: np.array(json.dumps(meta))})
    return path


def write_npz(handle: IO[bytes], arrays: dict[str, np.ndarray]) -> None:
    """`np.savez` with a fixed timestamp on every member, so the same arrays give the same bytes
    (np.savez stamps the current time into the zip)."""
    with zipfile.ZipFile(handle, "w", zipfile.ZIP_STORED, allowZip64=True) as archive:
        for name, value in arrays.items():
            member = zipfile.ZipInfo(f"{name}.npy", date_time=(1980, 1, 1, 0, 0, 0))
            with archive.open(member, "w", force_zip64=True) as out:
                np.lib.format.write_array(out, np.asanyarray(value), allow_pickle=False)


class _Arrays(dict):
    """The arrays of a loaded file; a missing one is the file's fault, said with its name."""

    def __init__(self, path: Path, arrays: dict[str, np.ndarray]):
        super().__init__(arrays)
        self.path = path

    def __missing__(self, name: str) -> np.ndarray:
        raise InvalidInput(f"{self.path} lacks the array {name!r} (a file of another version, or corrupt)")


#: how many times its size on disk a file's arrays may hold when inflated (the library's own files are stored,
#: not compressed: once); a member that declares more is refused before anything is inflated
MAX_INFLATION = 20
#: bytes, the most the metadata member may hold
MAX_METADATA_BYTES = 16 * 2**20


def _array_header(archive: zipfile.ZipFile, info: zipfile.ZipInfo) -> tuple[tuple[int, ...], bool, np.dtype, int]:
    """A member's .npy header, read without inflating its data: shape, Fortran order, dtype and data bytes."""
    if not info.filename.endswith(".npy"):
        raise InvalidInput(f"member {info.filename!r} is not an array")
    with archive.open(info) as member:
        version = np.lib.format.read_magic(member)
        read_header = (np.lib.format.read_array_header_1_0 if version == (1, 0)
                       else np.lib.format.read_array_header_2_0)
        shape, fortran, dtype = read_header(member)
        offset = member.tell()
    if dtype.hasobject:
        raise InvalidInput(f"member {info.filename!r} holds Python objects")
    size = int(np.prod(shape, dtype=np.int64)) * dtype.itemsize
    if size != info.file_size - offset:
        raise InvalidInput(f"member {info.filename!r} declares shape {shape} of {dtype} ({size} bytes) but "
                           f"holds {info.file_size - offset} bytes")
    return tuple(shape), fortran, dtype, size


def _read_member(archive: zipfile.ZipFile, info: zipfile.ZipInfo,
                 header: tuple[tuple[int, ...], bool, np.dtype, int] | None = None) -> np.ndarray:
    """A member's array; `header` is its `_array_header` when already read."""
    shape, fortran, dtype, size = header or _array_header(archive, info)
    with archive.open(info) as member:
        member.read(info.file_size - size)
        data = np.frombuffer(member.read(size), dtype=dtype, count=int(np.prod(shape, dtype=np.int64)))
    return data.reshape(shape, order="F" if fortran else "C").copy()


def _read_file(path: Path, kind: str, required: dict[str, tuple[int | None, ...]]) -> tuple[dict[str, np.ndarray], dict]:
    """The metadata and arrays of an .npz file, checked in the order that bounds what a hostile file can cost:
    the members' declared sizes against the file's size on disk (`MAX_INFLATION`), the metadata (its kind and
    schema), then every header's shape against `required`, and only then the arrays' data; no pickles."""
    allowed = MAX_INFLATION * max(path.stat().st_size, 1)
    with zipfile.ZipFile(path) as archive:
        members = {info.filename: info for info in archive.infolist()}
        declared = sum(info.file_size for info in members.values())
        if declared > allowed:
            raise _Refused(f"its members would inflate to {declared} bytes, more than {MAX_INFLATION} times the "
                               f"file's {path.stat().st_size} bytes (a zip bomb?)")
        info = members.pop(f"{_METADATA_KEY}.npy", None)
        if info is None:
            raise _Refused("it has no metadata")
        if info.file_size > MAX_METADATA_BYTES:
            raise _Refused(f"its metadata declares {info.file_size} bytes, more than {MAX_METADATA_BYTES}")
        try:
            meta = json.loads(str(_read_member(archive, info)))
        except (json.JSONDecodeError, UnicodeDecodeError) as error:
            raise _Refused(f"its metadata is corrupt: {error}") from None
        if not isinstance(meta, dict):
            raise _Refused(f"its metadata is corrupt: a JSON {type(meta).__name__}, not an object")
        if meta.get("kind") != kind:
            raise _Refused(f"it holds a {meta.get('kind')!r}, not a {kind!r}")
        if meta.get("schema") != SCHEMA_VERSION:
            raise _Refused(f"it has schema version {meta.get('schema')!r}; this library reads {SCHEMA_VERSION}")
        headers = {name[:-4]: _array_header(archive, info) for name, info in members.items()}
        for name, shape in required.items():
            if name not in headers:
                raise _Refused(f"it lacks the array {name!r}")
            got = headers[name][0]
            if len(got) != len(shape) or any(s is not None and s != g for s, g in zip(shape, got)):
                raise _Refused(f"its array {name!r} has shape {got}, expected {shape}")
        return {name[:-4]: _read_member(archive, info, headers[name[:-4]]) for name, info in members.items()}, meta


def npz_kind(path: str | os.PathLike) -> str:
    """The kind a file written by `save_npz` declares ("som", "ukr", ...), its data unread.

    Args:
        path: the .npz file.

    Returns:
        The kind.

    Raises:
        InvalidInput: no such file, or one that is not a readable file of the library's; the message names it.
    """
    return str(npz_metadata(path)["kind"])


def npz_metadata(path: str | os.PathLike) -> dict:
    """The metadata a file written by `save_npz` declares (its kind, its version, what `save` was given as `extra`),
    its data unread.

    Args:
        path: the .npz file.

    Returns:
        The metadata.

    Raises:
        InvalidInput: no such file, or one that is not a readable file of the library's; the message names it.
    """
    path = check_input_file(path, "path")
    try:
        with zipfile.ZipFile(path) as archive:
            info = archive.getinfo(f"{_METADATA_KEY}.npy")
            if info.file_size > MAX_METADATA_BYTES:
                raise _Refused(f"its metadata declares {info.file_size} bytes, more than {MAX_METADATA_BYTES}")
            meta = json.loads(str(_read_member(archive, info)))
        str(meta["kind"])  # a file without a kind is not one of the library's
        return dict(meta)
    except _Refused as error:
        raise InvalidInput(f"{path}: {error}") from None
    except Exception as error:  # noqa: BLE001 - whatever a corrupt file does to the parser, the file is at fault
        raise InvalidInput(f"{path} is not a readable .npz file of graspmanifold's (truncated, corrupt or "
                           f"foreign?): {type(error).__name__}: {error}") from None


class _Refused(InvalidInput):
    """A file refused for what it declares (another kind, a missing array, a bomb): said as it is, not as
    corruption."""


def load_npz(path: str | os.PathLike, kind: str, required: dict[str, tuple[int | None, ...]]
             ) -> tuple[dict[str, np.ndarray], dict]:
    """Load a file written by `save_npz` and check its kind, schema and the shapes of `required`.

    Args:
        path: the .npz file.
        kind: the kind of file expected ("posture_set", "som", "evaluation", ...).
        required: array names and their shapes, None matching any length.

    Returns:
        The arrays (a missing one, asked for later, raises a ValueError naming the file) and the metadata.

    Raises:
        MissingFile: there is no such file (a `FileNotFoundError`).
        ValueError: the file is truncated, corrupt, foreign, of another kind or schema, lacks an array, or
            would inflate to more than `MAX_INFLATION` times its size; the message names it.
    """
    path = check_input_file(path, "path")
    try:
        arrays, meta = _read_file(path, kind, required)
    except _Refused as error:
        raise InvalidInput(f"{path}: {error}") from None
    except Exception as error:  # noqa: BLE001 - whatever a corrupt file does to the parser, the file is at fault
        raise InvalidInput(f"{path} is not a readable .npz file (truncated or corrupt?): "
                           f"{type(error).__name__}: {error}") from None
    return _Arrays(path, arrays), meta


class NpzRecord:
    """The one way the library's values are saved and read (`save_npz` / `load_npz`: atomic, a kind and a schema,
    no pickles, shapes checked before the data is read): a posture set, a posture database, a SOM and an evaluation
    say only what they hold. A subclass sets `NPZ_KIND` and `NPZ_REQUIRED` (array names and shapes, None any
    length) and writes `_to_npz` (its arrays and metadata) and `_from_npz` (itself from them).
    """

    NPZ_KIND: str = ""
    NPZ_REQUIRED: dict[str, tuple[int | None, ...]] = {}

    def _to_npz(self) -> tuple[dict[str, np.ndarray], dict]:
        raise NotImplementedError

    @classmethod
    def _from_npz(cls, arrays: dict[str, np.ndarray], meta: dict, path: Path) -> Self:
        raise NotImplementedError

    def save(self, path: str | os.PathLike, *, overwrite: bool = True, extra: dict | None = None) -> Path:
        """Write it to an .npz file, atomically (a reader never sees half of it).

        Args:
            path: the file, ending in .npz.
            overwrite: replace an existing file (False: refuse it with FileExistsError).
            extra: more metadata to store beside its own.

        Returns:
            The path written.
        """
        arrays, meta = self._to_npz()
        return save_npz(path, self.NPZ_KIND, arrays, {**meta, **(extra or {})}, overwrite=overwrite)

    @classmethod
    def load(cls, path: str | os.PathLike) -> Self:
        """Read one written by `save`, checking its kind, schema and array shapes.

        Args:
            path: the .npz file.

        Returns:
            The value.

        Raises:
            ValueError: the file is missing, truncated, corrupt or of another kind; the message names it.
        """
        return cls.load_with_metadata(path)[0]

    @classmethod
    def load_with_metadata(cls, path: str | os.PathLike) -> tuple[Self, dict]:
        """`load`, with the file's metadata (what `save` was given as `extra` among it).

        Args:
            path: the .npz file.

        Returns:
            The value and the metadata.
        """
        arrays, meta = load_npz(path, cls.NPZ_KIND, cls.NPZ_REQUIRED)
        return cls._from_npz(arrays, dict(meta), Path(path)), meta


class Tabular:
    """What leaves the library as a table: a class with `rows()` (one dict per row, the same keys) gets `to_csv`
    and `to_frame` from this mixin."""

    def rows(self) -> list[dict]:
        """One dict per row, the same keys in the same order."""
        raise NotImplementedError

    def to_csv(self, path: str | os.PathLike) -> Path:
        """The rows as a CSV table (`rows`), written atomically; no extra package needed.

        Args:
            path: the file, ending in .csv.

        Returns:
            The path written.
        """
        return write_csv(path, self.rows())

    def to_frame(self) -> object:
        """The rows as a pandas DataFrame (pandas: the `tables` extra).

        Returns:
            The `pandas.DataFrame`, one row per row of `rows`.
        """
        return data_frame(self.rows())


def markdown_table(header: Sequence[object], rows: Iterable[Sequence[object]]) -> list[str]:
    """A markdown table: the one writer of every table in the library's reports.

    Args:
        header: the column names.
        rows: the cells of each row (any values, written with `str`), as many as the header has.

    Returns:
        The table's lines: the header, its rule, a line per row.
    """
    lines = [markdown_row(header), "|" + "---|" * len(header)]
    for row in rows:
        if len(row) != len(header):
            raise InvalidInput(f"rows must have {len(header)} cells like the header, got {len(row)}: {list(row)}")
        lines.append(markdown_row(row))
    return lines


def markdown_row(cells: Sequence[object]) -> str:
    """One row of a markdown table (`markdown_table`), for a table printed row by row as it is measured.

    Args:
        cells: the row's cells (any values, written with `str`; a '|' is escaped and a line break becomes a space,
            so that a file name holding one keeps the table whole).

    Returns:
        The row's line.
    """
    return "| " + " | ".join(" ".join(str(cell).replace("|", "\\|").splitlines()) for cell in cells) + " |"


def write_csv(path: str | os.PathLike, rows: list[dict]) -> Path:
    """Rows of one table (dicts with the same keys, in order) as a CSV file with a header, written atomically.

    Args:
        path: the file, ending in .csv.
        rows: the table's rows.

    Returns:
        The path written.
    """
    path = Path(path)
    if path.suffix != ".csv":
        raise InvalidInput(f"path must end in .csv, got {str(path)!r}")
    columns = list(rows[0]) if rows else []
    with atomic_write(path, "w") as handle:
        writer = csv.DictWriter(handle, fieldnames=columns, lineterminator="\n")
        writer.writeheader()
        writer.writerows(rows)
    return path


def data_frame(rows: list[dict]) -> object:
    """Rows of one table as a pandas DataFrame (pandas: the `tables` extra).

    Args:
        rows: the table's rows (dicts with the same keys).

    Returns:
        The `pandas.DataFrame`, one row per dict.
    """
    try:
        import pandas
    except ImportError as error:
        raise ImportError("a DataFrame needs pandas: pip install 'graspmanifold[tables]' (from a checkout: pip install "
                          "'.[tables]'); to_csv works without it") from error
    return pandas.DataFrame(rows)
