"""How a scene reaches the workers, and the content hash that names it.

Two ways, chosen by the user:

- **by value** (the default): the client loads the scene, records every file the
  loader opened (the scene file, its includes, meshes, textures, environment maps),
  and ships their bytes. Dask sends them to each worker once (the source is
  scattered and tasks refer to it); a worker writes them into
  ``$TMPDIR/glrender-scenes/<hash>/`` in the same layout and loads the scene from
  there. Nothing needs to be shared but the cluster.
- **from a path** (``--scene-on-workers PATH``, ``render(..., scene_on_workers=PATH)``):
  workers load PATH themselves, e.g. from a shared file system mounted where the
  client's copy may not be. They hash what they read and refuse a copy that differs
  from the client's.

A ``Scene`` object given to the Python API travels pickled.

Both ways carry the client's search path (``--search-path``, ``glrender.load``'s
``search_path``), so a worker resolves and refuses references as the client does: by value,
each search folder the bundle holds files of becomes the same folder of the bundle on the
worker; from a path, the folders are passed as given (the workers see them where the
client does).

The content hash covers each file's bytes and its path relative to the scene file's
folder, plus the loader parameters: workers cache loaded scenes (and renderers, with
their BVH and compiled kernel) under it.
"""
from __future__ import annotations

import hashlib
import os
import pickle
import tempfile
import threading
from collections import OrderedDict
from dataclasses import dataclass
from pathlib import Path

from ..errors import SceneError, UsageError

SCENE_CACHE = 4          # loaded scenes kept per worker process


@dataclass(frozen=True)
class SceneSource:
    digest: str                         # content hash
    label: str                          # for messages: the client's scene path
    params: tuple = ()                  # loader parameters, sorted (key, value) pairs
    root: str | None = None             # value: the scene file's name inside ``files``
    files: tuple = ()                   # value: ((relative path, bytes), ...)
    path: str | None = None             # path: the scene file as workers see it
    pickled: bytes | None = None        # a Scene object (Python API)
    search: tuple = ()                  # search folders: value: relative to the bundle's
                                        # folder; path: as given

    @property
    def mode(self) -> str:
        return "path" if self.path is not None else "pickle" if self.pickled is not None else "value"

    @property
    def nbytes(self) -> int:
        return sum(len(b) for _, b in self.files) + len(self.pickled or b"")


def content_digest(scene_file: Path, files, params: dict) -> str:
    """sha256 over each file's path relative to the scene file's folder and its bytes,
    plus the parameters."""
    folder = Path(scene_file).parent
    h = hashlib.sha256()
    for path in sorted({Path(p) for p in files}):
        rel = os.path.relpath(path, folder)
        data = Path(path).read_bytes()
        h.update(f"{rel}\0{len(data)}\0".encode())
        h.update(data)
    h.update(repr(sorted(params.items())).encode())
    return h.hexdigest()


def load_recorded(path, params: dict, search=None):
    """``glrender.load`` that also returns every file it read (the scene file first);
    ``search``: its search path (None: the current one, e.g. the command line's)."""
    from .. import load
    from ..scene.loaders.diagnostics import record_files

    path = Path(os.path.abspath(path))
    with record_files() as files:
        scene = load(path, search_path=search, **params)
    return scene, [path] + [f for f in files if f != path]


def from_file(scene_path, params: dict, scene_on_workers: str | None = None, search=None):
    """(scene as loaded here, SceneSource) for a scene file, loaded with the search path
    ``search`` (None: the current one, e.g. the command line's --search-path), which the
    workers use too."""
    from ..scene.loaders.scene_files import current_search_path

    folders = [os.path.abspath(f) for f in (current_search_path() if search is None else search)]
    scene, files = load_recorded(scene_path, params, folders)
    root = files[0]
    digest = content_digest(root, files, params)
    items = tuple(sorted(params.items()))
    if scene_on_workers is not None:
        return scene, SceneSource(digest, str(scene_path), items, path=str(scene_on_workers),
                                  search=tuple(folders))
    base = os.path.commonpath([str(f.parent) for f in files])
    blobs = tuple((os.path.relpath(f, base), f.read_bytes()) for f in sorted(set(files)))
    # each search folder the bundle holds files of, as the same folder inside the bundle (one
    # it holds nothing of allows nothing a worker reads)
    names = [name for name, _ in blobs]
    inside = tuple(rel for rel in (os.path.relpath(f, base) for f in folders)
                   if any(rel == "." or name.startswith(rel + os.sep) for name in names))
    return scene, SceneSource(digest, str(scene_path), items, root=os.path.relpath(root, base),
                              files=blobs, search=inside)


def from_scene(scene) -> SceneSource:
    """A SceneSource for an in-memory ``Scene`` (sent pickled)."""
    data = pickle.dumps(scene, protocol=pickle.HIGHEST_PROTOCOL)
    return SceneSource(hashlib.sha256(data).hexdigest(), scene.source, pickled=data)


# -- the worker's side ----------------------------------------------------------------------
_scenes: OrderedDict = OrderedDict()
_scenes_lock = threading.Lock()


def load_source(source: SceneSource):
    """The scene of ``source``, loaded once per worker process (by content hash)."""
    with _scenes_lock:
        if source.digest in _scenes:
            _scenes.move_to_end(source.digest)
            return _scenes[source.digest]
    scene = _load(source)
    with _scenes_lock:
        _scenes[source.digest] = scene
        while len(_scenes) > SCENE_CACHE:
            _scenes.popitem(last=False)
    return scene


def _load(source: SceneSource):
    import warnings

    params = dict(source.params)
    if source.mode == "pickle":
        return pickle.loads(source.pickled)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")      # the client has shown the loader's warnings
        if source.mode == "path":
            try:
                scene, files = load_recorded(source.path, params, source.search)
            except (SceneError, OSError) as exc:
                raise UsageError(f"a worker cannot read the scene ({str(exc).splitlines()[0]}); "
                                 f"--scene-on-workers names a path every worker can read") \
                    from None
            if content_digest(files[0], files, params) != source.digest:
                raise UsageError(f"the workers' copy of the scene at {source.path} differs from "
                                 f"{source.label} (a file changed or is missing on a worker): "
                                 f"sync it, or let glrender send the scene by value")
            return scene
        folder = _materialize(source)
        from .. import load

        return load(folder / source.root, search_path=[folder / rel for rel in source.search],
                    **params)


def _materialize(source: SceneSource) -> Path:
    """The bundle's files under $TMPDIR/glrender-scenes/<hash>/ (written once, atomically)."""
    base = Path(tempfile.gettempdir()) / "glrender-scenes"
    folder = base / source.digest
    if folder.is_dir():
        return folder
    base.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{source.digest[:16]}-", dir=base))
    try:
        for rel, data in source.files:
            target = tmp / rel
            target.parent.mkdir(parents=True, exist_ok=True)
            target.write_bytes(data)
        os.replace(tmp, folder)
    except OSError as exc:
        if folder.is_dir():           # another worker on this machine wrote it first
            return folder
        raise UsageError(f"a worker cannot store the scene's files under {base} "
                         f"({exc.strerror or exc})") from None
    finally:
        if tmp.exists():
            import shutil

            shutil.rmtree(tmp, ignore_errors=True)
    return folder
