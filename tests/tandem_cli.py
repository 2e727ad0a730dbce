"""tests/tandem_cli.py: what the Python tests that drive the `tandem` command share: running it
and counting checks (`ok   NAME` / `FAIL NAME (detail)`, exit 1 when any failed)."""
import os
import subprocess
import sys
import time


class Checks:
    def __init__(self, tandem):
        self.tandem = tandem
        self.failures = []

    def check(self, name, ok, detail=""):
        print(("ok   " if ok else "FAIL ") + name + (f"  ({detail})" if detail else ""))
        if not ok:
            self.failures.append(name)

    def run(self, *args, expect=0):
        """`tandem ARGS`; stops the test when the exit status is not `expect` (None: any)."""
        t0 = time.monotonic()
        p = subprocess.run([self.tandem, *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                           text=True)
        if os.environ.get("TANDEM_TEST_TIMES"):  # where a test's minutes go (CI's budget)
            print(f"  [{time.monotonic() - t0:6.1f} s] tandem {' '.join(args)[:150]}", flush=True)
        if expect is not None and p.returncode != expect:
            sys.exit(f"tandem {' '.join(args)}: exit {p.returncode}\n{p.stderr}")
        return p

    def finish(self):
        print("FAILED: " + ", ".join(self.failures) if self.failures else "all passed")
        sys.exit(1 if self.failures else 0)
