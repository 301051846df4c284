"""Counting checks for the Python tests, as tests/support/testlib.h does for the C ones: a test
calls check() as often as it likes and ends with done(), which prints "N passed, M failed" and
exits the process, non-zero when a check failed. It exits itself rather than returning the status:
four tests once ended on a bare `done()`, so their failures printed FAIL and still passed."""
import sys

passed = failed = 0


def check(cond, msg):
    global passed, failed
    if cond:
        passed += 1
    else:
        failed += 1
        print("FAIL:", msg, file=sys.stderr)


def done():
    print(f"{passed} passed, {failed} failed")
    sys.stdout.flush()
    raise SystemExit(1 if failed else 0)
