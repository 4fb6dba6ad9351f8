"""Files inside USDZ packages (``asset.usdz[tex/wood.png]``), which OpenImageIO and OpenVDB
cannot open by that path: each is copied once, by USD's asset resolver, into a cache directory
under the system's temporary directory, named by the hash of its bytes, and read from there.
The copies are kept between runs (a package read again copies nothing)."""

from __future__ import annotations

import hashlib
import os
import tempfile
from functools import lru_cache
from pathlib import Path

from pxr import Ar

CACHE = Path(tempfile.gettempdir()) / f"penumbra-packaged-files-{os.getuid()}"


def local_path(resolved: str) -> str:
    """A path the renderer's libraries can open for resolved asset path ``resolved``: itself,
    or for a file inside a package its cached copy (``resolved`` when the package does not
    hold it: the delegate reports it missing)."""
    if not resolved or not Ar.IsPackageRelativePath(resolved):
        return resolved
    package, _ = Ar.SplitPackageRelativePathOuter(resolved)
    try:
        status = os.stat(package)
    except OSError:
        return resolved
    return _copied(resolved, status.st_size, status.st_mtime_ns)


@lru_cache(maxsize=1024)
def _copied(resolved: str, package_size: int, package_modified: int) -> str:
    """The cached copy of package member ``resolved`` (the package's size and modification
    time key the cache, so that a package written again is read again)."""
    asset = Ar.GetResolver().OpenAsset(Ar.ResolvedPath(resolved))
    if asset is None:
        return resolved
    data = asset.GetBuffer()
    _, member = Ar.SplitPackageRelativePathInner(resolved)
    path = CACHE / f"{hashlib.sha256(data).hexdigest()[:32]}{Path(member).suffix.lower()}"
    if not path.exists():
        CACHE.mkdir(parents=True, exist_ok=True)
        partial = path.with_name(f"{path.name}.{os.getpid()}.partial")
        partial.write_bytes(data)
        os.replace(partial, path)  # whole or not at all, whoever else copies it too
    return str(path)
