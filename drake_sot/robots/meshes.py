"""Mesh conversion for Drake: STL/DAE → Wavefront OBJ, cached on disk by content hash.

Drake registers a ``Mesh`` as proximity (collision) geometry only from .obj/.vtk/.gltf, and
the robots of ``example-robot-data`` ship STL (TALOS, G1) or COLLADA (iCub, Romeo) meshes,
some with a mirroring ``scale="1 -1 1"`` in the URDF. :func:`converted_mesh` converts a
mesh once, bakes the scale into the vertices (a mirror flips the faces' winding back, so
that normals still point outwards) and keeps the result in a cache directory.

The conversion uses ``trimesh``: it reads STL, OBJ, PLY, GLB and (with ``pycollada``)
COLLADA into one triangle-mesh type and writes OBJ, its ``apply_transform`` keeps the
winding right under a mirror, and it decimates large meshes (with ``fast-simplification``)
to :data:`MAX_FACES` triangles. ``meshio`` was the other candidate; it is a volume-mesh
library (cells, point data), reads no COLLADA and has no notion of a mirrored winding.

Cache. The file name is ``<stem>-<key>.obj`` where the key hashes the source's bytes, the
scale, :data:`MAX_FACES` and :data:`FORMAT_VERSION`: an edited source or a new scale is a new entry, and
nothing else ever invalidates one. An entry is written to a temporary file and renamed
(no half-written entry under the final name) and ends with :data:`_END_MARK`; an entry
without it (truncated, overwritten by something else) is rebuilt. The directory is
``$DRAKE_SOT_MESH_CACHE`` when set, else ``~/.cache/drake_sot/meshes``.

No pydrake import here: this is file handling only.
"""

from __future__ import annotations

import hashlib
import os
import tempfile
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from drake_sot.robots.errors import RobotFileError, RobotFileMissing

#: Bump when the conversion changes: every cached entry is then rebuilt.
FORMAT_VERSION = 2
#: A mesh with more triangles is decimated to this many (quadric decimation): the CAD
#: meshes of TALOS hold ~480k triangles in all, which makes a recorded replay ~100 MB;
#: a visual needs no more.
MAX_FACES = 3000
_END_MARK = "# drake_sot mesh end"
#: Environment variable that moves the cache.
CACHE_ENV = "DRAKE_SOT_MESH_CACHE"


def cache_dir() -> Path:
    """The mesh cache directory (``$DRAKE_SOT_MESH_CACHE`` or ``~/.cache/drake_sot/meshes``).

    Raises:
        RobotFileError: the variable is unset and there is no home directory to default to
            (``$HOME`` unset and a user id without a passwd entry, as in a container run as
            another user): the message says to set the variable.
    """
    env = os.environ.get(CACHE_ENV)
    if env:
        return Path(env)
    try:
        home = Path.home()
    except RuntimeError:  # pathlib's "Could not determine home directory"
        raise RobotFileError(
            f"mesh cache: no home directory to keep it in ($HOME is unset and user id {os.getuid()} "
            f"has no home): set ${CACHE_ENV} to a writable directory"
        ) from None
    return home / ".cache" / "drake_sot" / "meshes"


def cache_key(source: Path, scale: Sequence[float]) -> str:
    """The key of a conversion: a hash of the source's bytes, the scale and the format."""
    digest = hashlib.sha256(source.read_bytes())
    digest.update(repr((tuple(float(s) for s in scale), FORMAT_VERSION, MAX_FACES)).encode())
    return digest.hexdigest()[:20]


def _entry_is_complete(path: Path) -> bool:
    """True when the entry ends with the end mark (it was written out completely)."""
    try:
        with path.open("rb") as f:
            f.seek(0, os.SEEK_END)
            size = f.tell()
            f.seek(max(0, size - 64))
            return f.read().decode("ascii", errors="replace").rstrip().endswith(_END_MARK)
    except OSError:
        return False


def converted_mesh(
    source: str | Path, scale: Sequence[float] = (1.0, 1.0, 1.0), directory: Path | None = None
) -> Path:
    """The OBJ file of mesh ``source`` scaled by ``scale`` (3 factors, a negative one mirrors),
    converted on first use and cached in ``directory`` (default :func:`cache_dir`).

    An .obj source with unit scale is returned as it is.

    Raises:
        RobotFileMissing: ``source`` does not exist (the message names it).
        RobotFileError: ``source`` cannot be read as a mesh (garbage, truncated) or holds no
            triangles; the cache ``directory`` is not a directory or cannot be written (each
            naming the file), or none was given and :func:`cache_dir` has none.
        ValueError: ``scale`` is not 3 finite non-zero factors.
    """
    source = Path(source)
    factors = np.asarray(scale, dtype=float)
    if factors.shape != (3,) or not np.all(np.isfinite(factors)) or np.any(factors == 0.0):
        raise ValueError(f"mesh {source}: scale {tuple(scale)!r} must be 3 finite non-zero factors")
    if not source.is_file():
        raise RobotFileMissing(f"mesh file {source} does not exist")
    if source.suffix.lower() == ".obj" and np.all(factors == 1.0):
        return source
    directory = cache_dir() if directory is None else Path(directory)
    if directory.exists() and not directory.is_dir():
        raise RobotFileError(f"mesh cache {directory} (${CACHE_ENV} or its default) is not a directory")
    target = directory / f"{source.stem}-{cache_key(source, factors)}.obj"
    if _entry_is_complete(target):
        return target
    import trimesh  # the optional extra "robots"; imported only when a mesh must be converted

    try:
        mesh = trimesh.load(source, force="mesh", process=False)
    except Exception as exc:  # noqa: BLE001 - a third-party reader of any bytes raises anything
        raise RobotFileError(
            f"mesh file {source}: cannot be read as a mesh ({type(exc).__name__}: {exc}): corrupt?"
        ) from None
    if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
        raise RobotFileError(f"mesh file {source}: no triangles to convert")
    if len(mesh.faces) > MAX_FACES:
        mesh = mesh.simplify_quadric_decimation(face_count=MAX_FACES)
    mesh.apply_transform(np.diag([*factors, 1.0]))  # a mirror also flips the winding back
    text = mesh.export(file_type="obj", include_normals=False, include_texture=False, digits=5)
    temporary: Path | None = None
    try:
        directory.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile("w", dir=directory, suffix=".tmp", delete=False) as f:
            temporary = Path(f.name)
            f.write(
                f"# {source.name} scaled by {tuple(factors.tolist())}, drake_sot format {FORMAT_VERSION}\n"
            )
            f.write(text)
            f.write(f"\n{_END_MARK}\n")
        os.replace(temporary, target)
    except OSError as exc:  # a full disk, no permission: no half-written entry is left
        if temporary is not None:
            temporary.unlink(missing_ok=True)
        raise RobotFileError(
            f"mesh cache {directory}: cannot write {target.name}: {exc.strerror or exc}"
        ) from None
    return target
