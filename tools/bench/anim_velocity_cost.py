#!/usr/bin/env python3
"""The velocity search's CPU (issue 12, docs/bench/animation.md round 6), as a ratio between two
libraries measured in one session: per case, the process CPU of csi's default run minus that of
the same run with the velocity it found given (the same basis and solve otherwise). Run it once
per library, alternating, on a shared machine; compare the ratios, never the seconds.

    CSI_LIBRARY=BASE/sdk/libcsi.so .venv/bin/python tools/bench/anim_velocity_cost.py --reps 2
    CSI_LIBRARY=build/sdk/libcsi.so .venv/bin/python tools/bench/anim_velocity_cost.py --reps 2

Cases are bench_animation.py's procedural volumes (its --data cache), seed 0. Prints one line per
case: the search's CPU seconds and the whole run's, per repetition."""
import argparse
import os
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

import bench_animation as ba  # noqa: E402
import csi  # noqa: E402


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--cases", default="pan:0.03,pan+disc:0.1,panfast:0.03", help="volume:rate,...")
    ap.add_argument("--size", default="128x128x32")
    ap.add_argument("--reps", type=int, default=2)
    ap.add_argument("--data", default=os.path.join(os.path.expanduser("~"), ".cache", "csi", "bench-anim"))
    a = ap.parse_args()
    size = tuple(int(v) for v in a.size.split("x"))
    for item in a.cases.split(","):
        name, rate = item.split(":")
        case = ba.procedural_case(name, 0, float(rate), size, os.path.join(a.data, "procedural"))
        out = []
        for _ in range(a.reps):
            c0 = time.process_time()
            r = csi.reconstruct(case.pos, case.vals, case.grid)
            c1 = time.process_time()
            vx, vy = float(r.options["motion_vx"]), float(r.options["motion_vy"])
            csi.reconstruct(case.pos, case.vals, case.grid, motion_velocity="given", motion_vx=vx, motion_vy=vy)
            c2 = time.process_time()
            out.append(f"{(c1 - c0) - (c2 - c1):.2f}/{c1 - c0:.2f}")
        print(name, rate, "search/run CPU s:", " ".join(out), flush=True)


if __name__ == "__main__":
    main()
