"""trms-ident: DREM parameter identification for the Twin Rotor MIMO System.

    import trms_ident as ti
    est = ti.estimate("log.csv")     # path, pandas DataFrame or Log; see trms_ident.api
    pooled = ti.estimate_joint(["a.csv", "b.mat"])   # one bench from several logs
"""
from pathlib import Path as _Path

from ._cache import configure as _configure_cache

__version__ = "0.1.0"
#: said by the CLI when the compiled kernels cannot be cached beside a read-only install
CACHE_NOTE = _configure_cache(_Path(__file__).resolve().parent.parent)

__all__ = ["__version__", "diagnose", "estimate", "estimate_joint", "log_frame", "simulate"]


def __getattr__(name):  # the library face loads numpy and friends only when used (the CLI starts fast)
    if name in ("estimate", "estimate_joint", "diagnose", "simulate", "log_frame", "Estimate", "JointEstimate"):
        from . import api

        return getattr(api, name)
    raise AttributeError(f"module 'trms_ident' has no attribute {name!r}")
