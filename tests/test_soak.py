#!/usr/bin/python3
"""tests/test_soak.py TANDEM: a short soak (`tandem bench --soak`): every front-end and denoiser
through render's frame loop for 240 frames; after the warm-up the process's resident memory
grows by less than 1 KB a frame and 2 MB in all, malloc's bytes in use by less than 32 bytes a
frame, its open descriptors and Tandem's live device allocations stay the same
(docs/reliability.md has a 10,000-frame run). Then the viewer's own loop
(`tandem view --soak`, under Xvfb): flat over 200 frames, and over eight cycles of switching
through every denoiser and both front-ends (each switch rebuilds the pipeline) the allocations,
descriptors and malloc's bytes in use at the start of each cycle the same. Release build only: the
sanitizers' allocator keeps freed memory in quarantine, and LeakSanitizer checks leaks there."""
import json
import os
import shutil
import subprocess
import sys
import tempfile

from tandem_cli import Checks


def main():
    c = Checks(sys.argv[1])
    p = c.run("bench", "--soak", "240", "--size", "48x32", "--json")
    out = json.loads(p.stdout)
    runs = out["runs"]
    c.check("soak: every front-end and denoiser ran",
            {(r["frontend"], r["denoiser"]) for r in runs} >=
            {(f, d) for f in ("embree", "vk") for d in ("asvgf", "svgf", "off", "recurrent")},
            str([(r["frontend"], r["denoiser"]) for r in runs]))
    for r in runs:
        name = f"{r['frontend']} {r['denoiser']}"
        c.check(f"soak {name}: {r['frames']} frames, flat after {r['warmup']}: RSS "
                f"{r['rss_mb_base']:.1f} -> {r['rss_mb_end']:.1f} MB "
                f"({r['rss_kb_per_frame']:+.3f} KB/frame), heap {r['heap_kb_per_frame'] * 1024:+.1f} "
                f"B/frame, fds {r['fds_base']} -> {r['fds_end']}, "
                f"vk allocations {r['vk_allocations_base']} -> {r['vk_allocations_end']}",
                r["flat"] and r["frames"] == 240)
    viewer(c)
    c.finish()


def view_soak(c, tmp, frames, script=None):
    cmd = ["xvfb-run", "-a", "-s", "-screen 0 1024x768x24", c.tandem, "view", "--frames",
           str(frames), "--size", "96x64", "--soak", "--json", "--out", tmp]
    if script:
        cmd += ["--script", script]
    p = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    ok = p.returncode == 0
    c.check(f"view --soak {frames} frames: exit 0", ok, p.stderr[-300:])
    return json.loads(p.stdout)["runs"][0] if ok else None


def viewer(c):
    if not shutil.which("xvfb-run"):
        print("skip the viewer's soak: no xvfb-run")
        return
    tmp = tempfile.mkdtemp(prefix="tandem_vsoak_")
    try:
        r = view_soak(c, tmp, 200)
        if r:
            c.check(f"viewer's loop: {r['frames']} frames, flat after {r['warmup']}: RSS "
                    f"{r['rss_mb_base']:.1f} -> {r['rss_mb_end']:.1f} MB "
                    f"({r['rss_kb_per_frame']:+.3f} KB/frame), heap "
                    f"{r['heap_kb_per_frame'] * 1024:+.1f} B/frame, fds {r['fds_base']} -> "
                    f"{r['fds_end']}, vk allocations {r['vk_allocations_base']} -> "
                    f"{r['vk_allocations_end']}", r["flat"] and r["frames"] == 200)
        # every 40 frames: denoisers 2, 3, 4, the other front-end, denoiser 1, back (a pipeline
        # rebuilt each time); the samples at each cycle's start compared from the third on
        cycle, n = 40, 8
        events = []
        for k in range(n):
            b = k * cycle
            events += [{"frame": b + 5, "key": "2"}, {"frame": b + 10, "key": "3"},
                       {"frame": b + 15, "key": "4"}, {"frame": b + 20, "key": "F"},
                       {"frame": b + 25, "key": "1"}, {"frame": b + 30, "key": "F"},
                       {"frame": b + 33, "mouse": [10, -3]}]
        events.append({"frame": n * cycle - 1, "exit": True})
        script = os.path.join(tmp, "cycle.json")
        json.dump({"events": events}, open(script, "w"))
        r = view_soak(c, tmp, n * cycle, script)
        if r:
            # (the first cycle is the warm-up: each denoiser's first pipeline, the allocator's
            # arenas growing to hold the largest; measured 0.9 MB between its end and the next)
            starts = [q for q in r["samples"] if q["frame"] % cycle == 0 and
                      q["frame"] >= 2 * cycle]
            rss = [q["rss_mb"] for q in starts]
            heap = [q["heap_mb"] * 1024 for q in starts]
            # a leak in a rebuild raises malloc's bytes in use cycle after cycle: the least of the
            # last three starts within 128 KB of the least of the first three (measured: +14 KB,
            # settling in the first cycles, then flat; a leak of 10 KB a rebuild, put in on
            # purpose, failed it at +181 KB). RSS is reported, not judged: it moves between two
            # levels 0.9 MB apart from one cycle to the next, the allocator's pages.
            h = len(heap) // 2
            rise = min(heap[h:]) - min(heap[:h])
            c.check(f"viewer, {n} cycles through every denoiser and both front-ends: at each "
                    f"cycle's start {sorted(set(q['vk_allocations'] for q in starts))} vk "
                    f"allocations, {sorted(set(q['fds'] for q in starts))} descriptors, heap "
                    f"floor {rise:+.1f} KB (RSS {min(rss):.2f} to {max(rss):.2f} MB)",
                    len(starts) == n - 2 and len(set(q["vk_allocations"] for q in starts)) == 1 and
                    len(set(q["fds"] for q in starts)) == 1 and rise < 128, str(starts))
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
