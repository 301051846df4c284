"""csi: compressive signal integration from Python.

    import csi
    res = csi.reconstruct_dump("samples.csid")            # or csi.reconstruct(pos, values, grid)
    res.image                                             # (H, W, C) float32
    res.options["tau"]                                    # every auto, as the library resolved it
    csi.reconstruct(pos, values, grid, solver="romp", lambda_=0.2, progress=print)

Importing the package needs only numpy; the C library (libcsi.so, found as csi._lib says) is
loaded on first use, and the renderer bridges import their renderer only when they run.
"""

__version__ = "0.2.0"

_API = ("CsiError", "Device", "Dump", "Options", "OutputSet", "Result", "cached_programs_dir", "default_grid_factor", "merge_partials", "options",
        "positions", "read_dump", "reconstruct", "reconstruct_check", "refine_apply", "refine_positions", "refine_settle", "refine_step_coverage", "reconstruct_dump", "reconstruct_tile", "version")


def __getattr__(name):
    if name in _API:
        from . import _lib
        return getattr(_lib, name)
    raise AttributeError(f"module 'csi' has no attribute {name!r}")


def __dir__():
    return sorted(list(globals()) + list(_API))
