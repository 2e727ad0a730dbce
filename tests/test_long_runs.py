#!/usr/bin/python3
"""tests/test_long_runs.py TANDEM [--quick]: runs that are interrupted and go on.

- A reference killed three times at random points (SIGINT, SIGTERM, SIGKILL) and resumed each
  time with `tandem reference --resume DIR` ends with the files of a run never interrupted, byte
  for byte (both estimators; the matched one summed on the device behind the Vulkan front-end).
- A render and a denoise interrupted: exit 130 / 143, the frames written whole (no .tmp left),
  run.json or timings.json saying where it stopped; a local sweep interrupted and resumed with
  `tandem sweep resume DIR`: the figures of one never interrupted.
- A reference whose device is lost partway keeps its checkpoints and resumes to the same files;
  a render whose device is lost or whose device memory runs out stops at once with the cause in
  words and leaves nothing (TANDEM_FAULT makes the driver's failures happen on demand).
- --resume refuses what it cannot go on with, by name.
"""
import json
import os
import random
import shutil
import signal
import subprocess
import sys
import tempfile
import time

from tandem_cli import Checks

SRC = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CORNELL = os.path.join(SRC, "data", "scenes", "cornell.gltf")
ATRIUM = os.path.join(SRC, "data", "scenes", "atrium.gltf")


def same_files(a, b):
    names = sorted(n for n in os.listdir(a) if n.startswith("frame_"))
    diff = [n for n in names if not os.path.exists(os.path.join(b, n)) or
            open(os.path.join(a, n), "rb").read() != open(os.path.join(b, n), "rb").read()]
    extra = sorted(set(n for n in os.listdir(b) if n.startswith("frame_")) - set(names))
    return names, diff + extra


def wait_for(p, path):
    """Waits until PATH exists or the process P has ended; returns the time then."""
    while p.poll() is None and not os.path.exists(path):
        time.sleep(0.005)
    return time.time()


def killed_and_resumed(c, tmp, name, args, rng, quick):
    """Returns the waits for the device the uninterrupted run made (TANDEM_FAULT counting them,
    never firing), for lost_and_resumed."""
    whole, cut = os.path.join(tmp, name + "_whole"), os.path.join(tmp, name + "_cut")
    env = dict(os.environ, TANDEM_FAULT="device-lost=1000000000")  # (counts, never fires)
    # The run's time is measured from its first checkpoint (reference.partial.json), so that the
    # shaders' compile (cold in a fresh cache, warm for the runs after it) is not counted in it.
    p = subprocess.Popen([c.tandem, "reference", *args, "--out", whole, "--quiet"], env=env,
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    t0 = wait_for(p, os.path.join(whole, "reference.partial.json"))
    out, err = p.communicate()
    r = subprocess.CompletedProcess(p.args, p.returncode, out, err)
    if r.returncode != 0:
        sys.exit(f"tandem reference {' '.join(args)}: exit {r.returncode}\n{r.stderr}")
    took = time.time() - t0
    kills = [signal.SIGINT, signal.SIGTERM, signal.SIGKILL]
    cmd = [c.tandem, "reference", *args, "--checkpoint", "0", "--out", cut, "--quiet"]
    stops = []
    for k, sig in enumerate(kills):
        p = subprocess.Popen(cmd, stderr=subprocess.PIPE, text=True)
        wait_for(p, os.path.join(cut, "reference.partial.json"))
        # somewhere in the middle of what is left (the run's own time, measured above)
        time.sleep(rng.uniform(0.15, 0.3) * took)
        p.send_signal(sig)
        err = p.communicate()[1]
        expect = {signal.SIGINT: 130, signal.SIGTERM: 143, signal.SIGKILL: -9}[sig]
        state = os.path.join(cut, "reference.partial.json")
        if p.returncode == 0:  # (it finished first: nothing left to interrupt or resume)
            stops.append("finished")
            break
        else:
            st = json.load(open(state))
            at = st.get("at", {}).get("frame", "-")
            stops.append(f"{sig.name} at frame {at}, {len(st['done'])} done")
            c.check(f"{name}: {sig.name}: exit {expect}, the state kept",
                    p.returncode == expect and (sig == signal.SIGKILL or
                                                st.get("interrupted") == sig.name),
                    f"exit {p.returncode}: {err.strip()[-200:]}")
            if sig != signal.SIGKILL:
                c.check(f"{name}: {sig.name}: says how to go on", "--resume" in err, err[-200:])
        leftovers = [n for n in os.listdir(cut) if n.endswith(".tmp")]
        c.check(f"{name}: no partial files after {sig.name}", not leftovers, str(leftovers))
        cmd = [c.tandem, "reference", "--resume", cut, "--quiet"]
    c.check(f"{name}: the first signal came before the run's end (a kill at 15-30% of its time)",
            stops[0] != "finished", "; ".join(stops))
    if stops[-1] != "finished":  # (a resumed run that ended before its signal is done)
        c.run("reference", "--resume", cut, "--quiet")
    names, diff = same_files(whole, cut)
    c.check(f"{name}: killed three times and resumed: {len(names)} files equal a run never "
            f"interrupted", not diff and len(names) >= 6, f"stops: {'; '.join(stops)}; differ: {diff}")
    c.check(f"{name}: finished: reference.json, no state or checkpoint left",
            os.path.exists(os.path.join(cut, "reference.json")) and
            not os.path.exists(os.path.join(cut, "reference.partial.json")) and
            not any(n.endswith(".sums") for n in os.listdir(cut)))
    a = json.load(open(os.path.join(whole, "reference.json")))
    b = json.load(open(os.path.join(cut, "reference.json")))
    c.check(f"{name}: reference.json's samples and noise the same",
            [(f["spp"], f["rel_error"]) for f in a["frames"]] ==
            [(f["spp"], f["rel_error"]) for f in b["frames"]])
    return fault_waits(r.stderr)


def fault_waits(err):
    """The waits for the device a run made (TANDEM_FAULT's closing line)."""
    for line in err.splitlines():
        if "TANDEM_FAULT:" in line and "waits for the device" in line:
            return int(line.split("TANDEM_FAULT:")[1].split()[0])
    return -1


def lost_and_resumed(c, tmp, name, args, rng, waits):
    """A reference whose device is lost partway (TANDEM_FAULT, as the driver reports it): a clear
    message, exit 1, its checkpoints kept; --resume ends with the files of a run never stopped
    (killed_and_resumed's, of the same arguments, which counted its `waits`)."""
    whole = os.path.join(tmp, name + "_whole")
    c.check(f"{name}: TANDEM_FAULT counts the run's waits for the device", waits > 10,
            f"{waits} waits")
    if waits <= 10:
        return
    at = rng.randint(waits // 2, waits - 2)
    lost = os.path.join(tmp, name + "_lost")
    env = dict(os.environ, TANDEM_FAULT=f"device-lost={at}")
    t0 = time.time()
    r = subprocess.run([c.tandem, "reference", *args, "--checkpoint", "0", "--out", lost,
                        "--quiet"], env=env, capture_output=True, text=True, timeout=300)
    state = os.path.join(lost, "reference.partial.json")
    c.check(f"{name}: device lost at wait {at} of {waits}: exit 1 in {time.time() - t0:.1f} s, "
            "said in words, the checkpoints kept, no partial file",
            r.returncode == 1 and "the device was lost" in r.stderr and
            f"--resume {lost}" in r.stderr and os.path.exists(state) and
            not any(n.endswith(".tmp") for n in os.listdir(lost)), r.stderr.strip()[-400:])
    c.run("reference", "--resume", lost, "--quiet")
    names, diff = same_files(whole, lost)
    c.check(f"{name}: lost device, resumed: {len(names)} files equal a run never stopped",
            not diff and len(names) >= 6, f"differ: {diff}")


def main():
    tandem = sys.argv[1]
    quick = "--quick" in sys.argv
    c = Checks(tandem)
    rng = random.Random(43)
    tmp = tempfile.mkdtemp(prefix="tandem_long_")
    try:
        spp = "512" if quick else "2048"
        killed_and_resumed(c, tmp, "unbiased", ["--scene", CORNELL, "--frontend", "embree",
                                                "--frames", "3", "--size", "48x32", "--spp", spp],
                           rng, quick)
        matched = ["--scene", CORNELL, "--frontend", "vk", "--estimator", "realtime", "--frames",
                   "3", "--size", "48x32", "--spp", spp, "--until-noise", "0.004"]
        waits = killed_and_resumed(c, tmp, "matched", matched, rng, quick)
        lost_and_resumed(c, tmp, "matched", matched, rng, waits)

        # a render whose device is lost, and one whose device memory runs out: exit 1 at once,
        # said in words, nothing left (TANDEM_FAULT: as the driver reports them)
        for fault, args, expect in (
                ("device-lost=140", ["--frames", "20", "--size", "64x40"],  # (mid-run: 207 waits)
                 ["the device was lost", "VK_ERROR_DEVICE_LOST"]),
                ("device-memory=4", ["--frames", "2", "--size", "640x360"],
                 ["out of device memory for '", "a smaller --size"])):
            out = os.path.join(tmp, "fault")
            r = subprocess.run([tandem, "render", "--scene", CORNELL, "--frontend", "vk", *args,
                                "--out", out, "--quiet"], capture_output=True, text=True,
                               env=dict(os.environ, TANDEM_FAULT=fault), timeout=300)
            c.check(f"render, {fault}: exit 1, {expect[0]!r}, no output",
                    r.returncode == 1 and all(e in r.stderr for e in expect) and
                    not os.path.exists(out), r.stderr.strip()[-300:])

        # out of device memory for the copy of atrium's static instances in one BLAS (52 MB:
        # fvk_scene.c merge_static; the allocations before it take under 30 MB at this size):
        # an optimisation, so the instances stay apart, with a warning, and the frame is made
        out = os.path.join(tmp, "merge")
        r = subprocess.run([tandem, "render", "--scene", ATRIUM, "--frontend", "vk", "--frames",
                            "1", "--size", "32x18", "--out", out, "--quiet"], capture_output=True,
                           text=True, env=dict(os.environ, TANDEM_FAULT="device-memory=45"),
                           timeout=600)
        c.check("render, device memory short for the merged static instances: they stay apart, "
                "said, exit 0", r.returncode == 0 and "static instances left apart" in r.stderr and
                os.path.exists(os.path.join(out, "frame_0000.png")), r.stderr.strip()[-300:])

        # a render interrupted between frames
        out = os.path.join(tmp, "render")
        p = subprocess.Popen([tandem, "render", "--scene", CORNELL, "--frontend", "embree",
                              "--frames", "400", "--size", "64x40", "--out", out, "--quiet"],
                             stderr=subprocess.PIPE, text=True)
        while p.poll() is None and not (os.path.isdir(out) and
                                        any(x.endswith(".png") for x in os.listdir(out))):
            time.sleep(0.01)
        time.sleep(0.5)
        second = c.run("render", "--scene", CORNELL, "--frontend", "embree", "--frames", "2",
                       "--size", "16x16", "--out", out, expect=None)
        c.check("a second run into a directory being written: refused, naming the first",
                second.returncode == 1 and "another tandem is writing there" in second.stderr and
                str(p.pid) in second.stderr, second.stderr[-200:])
        p.send_signal(signal.SIGINT)
        err = p.communicate()[1]
        run = json.load(open(os.path.join(out, "run.json"))) if os.path.exists(
            os.path.join(out, "run.json")) else {}
        exrs = sorted(n for n in os.listdir(out) if n.endswith(".exr"))
        pngs = sorted(n for n in os.listdir(out) if n.endswith(".png"))
        n = run.get("interrupted", {}).get("frames_written", -1)
        c.check("render: SIGINT: exit 130, run.json says where it stopped, its frames whole",
                p.returncode == 130 and 0 < n < 400 and len(exrs) == n and len(pngs) == n and
                run["interrupted"]["signal"] == "SIGINT" and
                run["interrupted"]["next_frame"] == n and
                not any(x.endswith(".tmp") or x == ".tandem.lock" for x in os.listdir(out)) and
                json.load(open(os.path.join(out, "timings.json")))["frames"][-1]["frame"] == n - 1,
                f"exit {p.returncode}, {n} written, {len(exrs)} EXR: {err[-200:]}")

        # a local sweep interrupted in its reference, then resumed: the same figures
        sw_args = ["bench", "--scene", CORNELL, "--sweep", "atrous=1,3", "--size", "40x24",
                   "--frames", "5", "--warmup", "2", "--spp", "128" if quick else "384"]
        whole, cut = os.path.join(tmp, "sweep_whole"), os.path.join(tmp, "sweep_cut")
        c.run(*sw_args, "--out", whole, "--quiet")
        p = subprocess.Popen([tandem, *sw_args, "--out", cut, "--quiet"], stderr=subprocess.PIPE,
                             text=True)
        # the signal goes once the reference has started (its checkpoint exists), not after a
        # share of the uninterrupted run's time: that one may have compiled the shaders cold,
        # and a sleep of 30% of it outlasted the whole second sweep on a fast machine
        wait_for(p, os.path.join(cut, "reference", "reference.partial.json"))
        p.send_signal(signal.SIGINT)
        err = p.communicate()[1]
        c.check("sweep: SIGINT: exit 130, says how to go on",
                p.returncode == 130 and "tandem sweep resume" in err, err[-300:])
        c.run("sweep", "resume", cut, "--quiet")
        a = json.load(open(os.path.join(whole, "sweep.json")))["runs"]
        b = json.load(open(os.path.join(cut, "sweep.json")))["runs"]
        c.check("sweep: resumed: every cell's relMSE and FLIP those of a sweep never interrupted",
                [(r["knobs"], r["relmse"], r["flip"]) for r in a] ==
                [(r["knobs"], r["relmse"], r["flip"]) for r in b],
                str([(r["relmse"], r["flip"]) for r in a + b]))

        # tandem denoise interrupted between frames
        caps = os.path.join(tmp, "caps")
        c.run("render", "--scene", CORNELL, "--frontend", "embree", "--denoiser", "off",
              "--frames", "60", "--size", "64x40", "--capture", "--out", caps, "--quiet")
        dn = os.path.join(tmp, "denoised")
        p = subprocess.Popen([tandem, "denoise", "--captures", caps, "--denoiser", "svgf",
                              "--out", dn, "--quiet"], stderr=subprocess.PIPE, text=True)
        while p.poll() is None and not (os.path.isdir(dn) and
                                        any(x.endswith(".png") for x in os.listdir(dn))):
            time.sleep(0.01)
        p.send_signal(signal.SIGTERM)  # (as soon as its first frame is out)
        err = p.communicate()[1]
        tj = json.load(open(os.path.join(dn, "timings.json")))
        n = tj.get("interrupted", {}).get("frames_written", -1)
        exrs = [x for x in os.listdir(dn) if x.endswith(".exr")]
        c.check("denoise: SIGTERM: exit 143, timings.json says where it stopped, its frames whole",
                p.returncode == 143 and 0 < n < 60 and len(exrs) == n == len(tj["frames"]),
                f"exit {p.returncode}, {n} written, {len(exrs)} EXR: {err[-200:]}")

        # an image the device cannot hold: refused by name before anything is written
        big = os.path.join(tmp, "big")
        r = c.run("render", "--scene", CORNELL, "--frontend", "vk", "--size", "20000x64",
                  "--frames", "1", "--out", big, expect=None)
        c.check("a frame wider than the device's largest image: exit 1, the limit named, no "
                "output", r.returncode == 1 and "largest 2D image" in r.stderr and
                "a smaller --size" in r.stderr and not os.path.exists(big), r.stderr[-200:])

        # a full disk (a 300 KB tmpfs, where the machine lets us mount one): the file named, the
        # run's output removed
        full = os.path.join(tmp, "full")
        os.makedirs(full)
        if subprocess.run(["mount", "-t", "tmpfs", "-o", "size=300k", "tmpfs", full],
                          capture_output=True).returncode == 0:
            try:
                for cmd in (["render", "--frames", "100"],
                            ["reference", "--frames", "100", "--spp", "4"]):
                    out = os.path.join(full, cmd[0])
                    r = c.run(*cmd, "--scene", CORNELL, "--frontend", "embree", "--size",
                              "64x40", "--out", out, expect=None)
                    c.check(f"{cmd[0]} onto a full disk: exit 1, the file named, nothing left",
                            r.returncode == 1 and full in r.stderr and
                            ("No space left" in r.stderr or "cannot write" in r.stderr or
                             "write failed" in r.stderr) and not os.path.exists(out),
                            r.stderr.strip()[-200:])
            finally:
                subprocess.run(["umount", full])
        else:
            print("skip full disk: this machine does not let the test mount a tmpfs")

        # what --resume refuses
        done = os.path.join(tmp, "unbiased_whole")
        for args, expect, msg in (
                (["--resume", os.path.join(tmp, "none")], 1, "reference.partial.json"),
                (["--resume", done], 1, "a finished one has reference.json"),
                (["--resume", os.path.join(tmp, "unbiased_cut"), "--spp", "8"], 2,
                 "takes the run's own options")):
            r = c.run("reference", *args, expect=None)
            c.check(f"--resume refuses: {msg}", r.returncode == expect and msg in r.stderr,
                    f"exit {r.returncode}: {r.stderr.strip()[-200:]}")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    c.finish()


if __name__ == "__main__":
    main()
