#!/usr/bin/python3
"""tests/test_soak.py TANDEM: a short soak (`tandem bench --soak`): every front-end and denoiser
through render's frame loop for 240 frames; after the warm-up the process's resident memory
grows by less than 1 KB a frame and 2 MB in all, its open descriptors and Tandem's live device
allocations stay the same (docs/reliability.md has a 10,000-frame run). Release build only: the
sanitizers' allocator keeps freed memory in quarantine, and LeakSanitizer checks leaks there."""
import json
import subprocess
import sys

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
                f"({r['rss_kb_per_frame']:+.3f} KB/frame), fds {r['fds_base']} -> {r['fds_end']}, "
                f"vk allocations {r['vk_allocations_base']} -> {r['vk_allocations_end']}",
                r["flat"] and r["frames"] == 240)
    c.finish()


if __name__ == "__main__":
    main()
