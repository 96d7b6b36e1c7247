"""Installed read-only and run by another user without a home: no crash, the kernels cached elsewhere."""
import os
import shutil
import stat
import subprocess
import sys
import sysconfig
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SYSTEM_PYTHON = shutil.which("python3", path="/usr/bin:/bin")


def _readable_by_others(path: Path) -> bool:
    return all(p.stat().st_mode & stat.S_IROTH and p.stat().st_mode & stat.S_IXOTH for p in (path, *path.parents)
               if p.is_dir())


def _same_minor(python: str) -> bool:
    out = subprocess.run([python, "-c", "import sys; print(sys.version_info[:2])"], capture_output=True, text=True)
    return out.stdout.strip() == str(sys.version_info[:2])


@pytest.mark.skipif(not hasattr(os, "geteuid") or os.geteuid() != 0, reason="needs root to run as another user")
def test_read_only_install_run_by_a_user_without_a_home(tmp_path):
    site = Path(sysconfig.get_paths()["purelib"])
    if not SYSTEM_PYTHON or not _same_minor(SYSTEM_PYTHON):
        pytest.skip("needs a system python3 of this minor version that another user may run")
    if not (_readable_by_others(ROOT) and _readable_by_others(site)):
        pytest.skip("this checkout or its packages are not readable by other users")
    import tempfile

    work = Path(tempfile.mkdtemp(prefix="trms-ro-"))  # pytest's own tmp folders are private to this user
    work.chmod(0o777)
    out = work / "out"
    cache = Path("/tmp") / "trms-ident-65534"
    shutil.rmtree(cache, ignore_errors=True)
    # the user 'nobody' cannot write the sources (they are this user's): a read-only install, as on a lab PC
    env = {"PATH": "/usr/bin:/bin", "PYTHONPATH": f"{ROOT}{os.pathsep}{site}"}  # no HOME
    res = subprocess.run([SYSTEM_PYTHON, "-m", "trms_ident", "estimate", str(ROOT / "sample_logs" / "paper_square.csv"),
                          "-o", str(out), "--no-report"], env=env, user=65534, group=65534, capture_output=True,
                         text=True, timeout=600, cwd=work)
    shutil.rmtree(work, ignore_errors=True) if res.returncode else None
    assert res.returncode == 0, res.stderr
    assert "note: the installed package is read-only: compiled kernels are cached in" in res.stderr
    assert "MODEL FITS" in res.stderr and (out / "result.json").exists()
    assert any(cache.rglob("*.nbi")), "numba wrote no cache index"
    shutil.rmtree(work, ignore_errors=True)


def test_cache_folder_choice(tmp_path, monkeypatch):
    from trms_ident import _cache

    monkeypatch.setenv("NUMBA_CACHE_DIR", "recorded")  # so that undo removes what configure() sets below
    monkeypatch.delenv("NUMBA_CACHE_DIR")
    assert _cache.configure(ROOT) is None or not os.access(ROOT / "trms_ident", os.W_OK)
    monkeypatch.setattr(_cache, "_writable", lambda p: p == tmp_path)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    note = _cache.configure(ROOT)
    assert os.environ["NUMBA_CACHE_DIR"] == str(tmp_path / "trms-ident" / "numba")
    assert "read-only" in note


def test_first_run_is_announced(tmp_path, monkeypatch):
    from trms_ident import _cache

    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path))
    assert not _cache.kernels_cached(ROOT)
    (tmp_path / "x").mkdir()
    (tmp_path / "x" / "fused._axis-40.py311.nbi").write_bytes(b"")
    assert _cache.kernels_cached(ROOT)


def test_the_suites_kernel_halves_compile_without_error():
    # conftest compiles the kernels in two processes before xdist's workers start; its failures are silent there
    # (the workers then compile as before, ~25 s slower on an empty cache), so a renamed warm-up shows here
    from .conftest import KERNEL_HALVES, compile_kernels_in_halves

    assert len(KERNEL_HALVES) == 2 and compile_kernels_in_halves() == [0, 0]
