"""Files written whole or not at all: a temporary name in the target's directory, renamed over
the target on success and removed on failure, so a reader never sees a partial file and a
failed run leaves nothing behind."""

from __future__ import annotations

import contextlib
import os
import tempfile


@contextlib.contextmanager
def target(path, suffix=""):
    """Yields a temporary path beside `path` (ending in suffix, for writers that need an
    extension); renames it to `path` when the block ends without an exception."""
    path = os.fspath(path)
    fd, tmp = tempfile.mkstemp(prefix="." + os.path.basename(path) + ".", suffix=suffix,
                               dir=os.path.dirname(os.path.abspath(path)))
    os.close(fd)
    try:
        yield tmp
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise
