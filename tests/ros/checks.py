"""What the tests over DDS share: each check printed and counted, the
summary and exit status, and message stamps as keys."""

RESULTS = []


def check(name, ok, detail):
    RESULTS.append(ok)
    print(f"{'ok  ' if ok else 'FAIL'} {name}: {detail}", flush=True)


def summary():
    """Prints the count of passed and failed checks; the exit status."""
    print(f"{sum(RESULTS)} passed, {len(RESULTS) - sum(RESULTS)} failed")
    return 0 if RESULTS and all(RESULTS) else 1


def key(stamp):
    """A stamp to the millisecond: the nodes' stamps go through f64
    seconds, which keep about 0.1 us of a Unix time."""
    return round(stamp.sec + 1e-9 * stamp.nanosec, 3)
