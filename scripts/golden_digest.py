#!/usr/bin/env python3
"""scripts/golden_digest.py OUT [TANDEM]: one line per output file of scripts/golden.sh (OUT/runs),
"PATH SHA256", with what legitimately changes from run to run left out: timings (keys and
columns named for times, rates and durations), the machine's paths (OUT, the source tree and
the binary become placeholders) and the lock files. Images, captures, sums and arrays are
digested byte for byte; JSON by its content with such keys dropped; CSV without such columns;
text with the paths replaced and the figures of timing lines dropped."""
import csv
import hashlib
import io
import json
import os
import re
import sys

# keys and columns that hold times, rates or durations: measured, not computed
TIMING = re.compile(
    r"(^|_)(ms|s|sec|secs|seconds|time|times|timed|wall|elapsed|per_s|mrays|mpaths|"
    r"gb_per_s|gbs|rate|duration_s|started|date|pid)($|_)|_ms($|_)|ms_|^wall|seconds|"
    r"back_to_back|timings|per_second|frontend_mrays|raw_mrays|floor_share|fraction_of_floor|"
    r"pareto",
    re.I)


# files made from the measured times (a sweep's Pareto plots and its report page)
TIMED_FILES = re.compile(r"sweep/report/(pareto_[a-z]+\.svg|index\.html)$")


def clean(v, subst):
    if isinstance(v, dict):
        return {k: clean(x, subst) for k, x in v.items() if not TIMING.search(k)}
    if isinstance(v, list):
        return [clean(x, subst) for x in v]
    if isinstance(v, str):
        for a, b in subst:
            v = v.replace(a, b)
        return v
    return v


def text_clean(t, subst):
    for a, b in subst:
        t = t.replace(a, b)
    # figures of a line that speaks of time: "in 1.2 s", "3.4 ms", "Mpaths/s"
    out = []
    for line in t.split("\n"):
        if re.search(r"\b(ms|s|sec|seconds|Mpaths/s|Mrays/s|GB/s)\b", line):
            line = re.sub(r"[0-9][0-9.e+-]*", "#", line)
        line = line.replace("  (Pareto)", "")  # (the fronts follow the times)
        out.append(line)
    return "\n".join(out)


def digest(path, subst):
    name = os.path.basename(path)
    data = open(path, "rb").read()
    ext = os.path.splitext(name)[1]
    if TIMED_FILES.search(path):  # (drawn from the times: that it is there is what counts)
        return "present"
    if ext in (".exr", ".png", ".npz", ".sums", ".npy", ".mp4", ".jpg"):
        return hashlib.sha256(data).hexdigest()
    text = data.decode("utf-8", "replace")
    if ext in (".json", ".out") or name.endswith(".json.tmp"):
        try:
            j = json.loads(text)
        except ValueError:
            j = None
        if j is not None:
            s = json.dumps(clean(j, subst), sort_keys=True)
            return hashlib.sha256(s.encode()).hexdigest()
    if ext == ".csv":
        rows = list(csv.reader(io.StringIO(text)))
        if rows:
            keep = [i for i, h in enumerate(rows[0]) if not TIMING.search(h)]
            rows = [[r[i] for i in keep if i < len(r)] for r in rows]
        s = json.dumps(clean(rows, subst))
        return hashlib.sha256(s.encode()).hexdigest()
    return hashlib.sha256(text_clean(text, subst).encode()).hexdigest()


def main():
    out = os.path.realpath(sys.argv[1])
    src = os.path.realpath(os.path.join(os.path.dirname(__file__), ".."))
    subst = [(out, "<OUT>")]
    if len(sys.argv) > 2:  # the binary's build directory (the tree it was built from may differ)
        b = os.path.dirname(os.path.realpath(sys.argv[2]))
        subst += [(b, "<BUILD>"), (os.path.dirname(b), "<SRC>")]
    subst.append((src, "<SRC>"))
    runs = os.path.join(out, "runs")
    for root, dirs, files in os.walk(runs):
        dirs.sort()
        for f in sorted(files):
            if f in (".tandem.lock", "timings.json"):
                continue
            p = os.path.join(root, f)
            rel = os.path.relpath(p, runs)
            print(rel, digest(p, subst))


if __name__ == "__main__":
    main()
