"""A Ctrl-C (SIGINT) during csi.reconstruct from Python: raised as KeyboardInterrupt, the
reconstruction cancelled at its next progress report rather than run to its end.

Python runs signal handlers only between its own bytecodes, so a SIGINT that arrives while the
library works used to be raised on entering the progress relay, where it could not be caught:
ctypes printed it as an ignored exception and the run ended as CSI_ERR_CANCELLED (with a
progress callback), or ran to its end (without one). Here the signal is sent from another
thread while the library works (ctypes releases the GIL during the call).
"""
import os
import signal
import sys
import threading

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "..", "host", "python"))
sys.path.insert(0, HERE)
import numpy as np  # noqa: E402

import csi  # noqa: E402
from checks import check, done  # noqa: E402

GRID = (1024, 1024, 1, 256, 256)


def interrupted(with_progress):
    """Reconstructs, sending SIGINT 50 ms after the first progress report (without a callback:
    0.5 s after the call); returns what the call raised and the reports after the signal."""
    pos = csi.positions(GRID, spp=2, seed=3)
    vals = np.random.default_rng(3).random((len(pos), 3)).astype(np.float32)
    sent, after = [], []
    timer = threading.Timer(0.05, lambda: (sent.append(True), os.kill(os.getpid(), signal.SIGINT)))

    def progress(phase, iteration, residual):
        if sent:
            after.append(phase)
        elif not timer.is_alive():
            timer.start()

    if not with_progress:  # no report to start it from: once the library has surely begun
        timer.interval = 0.5
        timer.start()
    try:
        csi.reconstruct(pos, vals, GRID, progress=progress if with_progress else None, max_iter=1000, tol=1e-9,
                        tau=1e-6)
    except KeyboardInterrupt:
        return "KeyboardInterrupt", after
    except csi.CsiError as e:
        return e.status, after
    return "finished", after


def main():
    got, after = interrupted(True)
    check(got == "KeyboardInterrupt", f"SIGINT during a reconstruction with a progress callback: {got}")
    check(len(after) <= 1, f"the run went on for {len(after)} progress reports after the signal")
    got, _ = interrupted(False)
    check(got == "KeyboardInterrupt", f"SIGINT during a reconstruction without a progress callback: {got}")
    # the handler of Python's own is back in place after the call
    check(signal.getsignal(signal.SIGINT) is signal.default_int_handler, "SIGINT's handler was not restored")
    return done()


if __name__ == "__main__":
    sys.exit(main())
