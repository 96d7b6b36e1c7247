"""Where numba keeps the compiled kernels: beside the sources when they are writable, else a user cache.

A read-only install (a shared lab machine, a system package) run by another user, even one without a home,
must not crash ("cannot cache function ...: no locator available").  Chosen before numba is imported;
NUMBA_CACHE_DIR set by the user wins.  Standard library only: imported by the package's __init__.
"""
from __future__ import annotations

import os
import tempfile
from pathlib import Path

PACKAGES = ("trms_ident", "trms_ident/model", "trms_ident/numerics", "trms_ident/diagnosis", "trms_ident/io", "sim")


def _writable(folder: Path) -> bool:
    return folder.is_dir() and os.access(folder, os.W_OK)


def user_cache_dir() -> Path:
    """$XDG_CACHE_HOME/trms-ident, else ~/.cache/trms-ident when the home is writable, else the temp folder."""
    xdg = os.environ.get("XDG_CACHE_HOME")
    if xdg and _writable(Path(xdg)):
        return Path(xdg) / "trms-ident"
    home = Path(os.path.expanduser("~"))
    if home.is_dir() and _writable(home if not (home / ".cache").exists() else home / ".cache"):
        return home / ".cache" / "trms-ident"
    uid = os.getuid() if hasattr(os, "getuid") else "user"
    return Path(tempfile.gettempdir()) / f"trms-ident-{uid}"


def configure(root: Path) -> str | None:
    """Set NUMBA_CACHE_DIR when the sources under ``root`` (site-packages) are not writable; returns a note
    saying where the kernels are cached then (None when nothing changed)."""
    if "NUMBA_CACHE_DIR" in os.environ:
        return None
    if all(_writable(root / p) for p in PACKAGES if (root / p).exists()):
        return None
    folder = user_cache_dir() / "numba"
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError:  # no writable cache anywhere it should be: a throw-away folder, compiled anew each run
        os.environ["NUMBA_CACHE_DIR"] = tempfile.mkdtemp(prefix="trms-ident-numba-")
        return "no writable cache folder: the compiled kernels are compiled anew on each run (~10 s)"
    os.environ["NUMBA_CACHE_DIR"] = str(folder)
    return f"the installed package is read-only: compiled kernels are cached in {folder}"


def kernels_cached(root: Path) -> bool:
    """Whether numba has cached the core kernel (numerics/fused.py) where this process will look for it."""
    folder = os.environ.get("NUMBA_CACHE_DIR")
    places = [Path(folder)] if folder else [root / "trms_ident" / "numerics" / "__pycache__"]
    return any(any(p.rglob("fused.*.nbi")) for p in places if p.is_dir())
