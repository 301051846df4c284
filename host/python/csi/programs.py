"""Finding and running csi's command-line programs (csi-positions, csi-reconstruct, ...).

Looked up, in order: $CSI_BUILD_DIR, the build/ directory of the source tree this package sits
in (host/python/csi -> ../../../build), then $PATH.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys


class ProgramError(RuntimeError):
    """A csi program is missing or failed; the message is its one-line error, code the exit
    status to pass on (2: bad input, 1: anything else)."""

    def __init__(self, message, code=1):
        super().__init__(message)
        self.code = code


def find(name: str) -> str:
    candidates = []
    if os.environ.get("CSI_BUILD_DIR"):
        candidates.append(os.path.join(os.environ["CSI_BUILD_DIR"], name))
    here = os.path.dirname(os.path.abspath(__file__))
    candidates.append(os.path.normpath(os.path.join(here, "..", "..", "..", "build", name)))
    for c in candidates:
        if os.path.isfile(c) and os.access(c, os.X_OK):
            return c
    found = shutil.which(name)
    if found:
        return found
    raise ProgramError(code=1, message=f"{name} not found (looked in $CSI_BUILD_DIR, {candidates[-1]} and $PATH): "
                       f"build csi first (cmake --build build) or set CSI_BUILD_DIR")


def run(name: str, args, quiet: bool = True) -> subprocess.CompletedProcess:
    """Runs a csi program; on failure raises ProgramError with the program's last stderr line."""
    proc = subprocess.run([find(name), *map(str, args)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    if proc.returncode != 0:
        lines = [ln for ln in proc.stderr.splitlines() if ln.strip()]
        raise ProgramError(lines[-1] if lines else f"{name} failed with exit code {proc.returncode}",
                           code=2 if proc.returncode == 2 else 1)
    if not quiet and proc.stderr:
        print(proc.stderr, end="", file=sys.stderr)
    return proc
