"""Counting checks for the Python tests, as tests/support/testlib.h does for the C ones: a test
calls check() as often as it likes and ends with `sys.exit(done())` ("N passed, M failed")."""
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
    return 1 if failed else 0
