"""What a user meets: whole-process times of csw, cold (empty kernel cache) and warm, against
a short Python script calling OpenCV's StereoBM (make bench-startup).

Every csw run is paired with a run of the OpenCV script, alternately, so that drifts in
the machine's load hit both alike; each figure is min / median / max over the pairs, and
ratios are taken pair by pair.  Peak memory is each process's own (wait4's ru_maxrss).
Writes Markdown to --output (and stdout).
"""

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from report_common import cpu_name, fill_template, now_utc, outside_kernels, spread

# The user's alternative: read the pair, match with StereoBM, write a PFM.
OPENCV_SCRIPT = """import sys
import cv2, imageio.v3 as iio, numpy as np
cv2.setNumThreads(1)
left, right = (iio.imread(p, mode="L") for p in sys.argv[1:3])
nd = -(-(int(sys.argv[4]) + 1) // 16) * 16
d = cv2.StereoBM_create(nd, 9).compute(left, right).astype(np.float32) / 16
d[d < 0] = np.inf
open(sys.argv[3], "wb").write(b"Pf\\n%d %d\\n-1\\n" % (d.shape[1], d.shape[0])
                              + np.flipud(d).astype("<f4").tobytes())
"""
CSW = [sys.executable, "-m", "csw_cli"]


def run(args, env=None):
    """(wall seconds, peak RSS in MB, exit status) of one process."""
    start = time.perf_counter()
    proc = subprocess.Popen(args, env=env, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)
    _, status, usage = os.wait4(proc.pid, 0)
    proc.returncode = status  # reaped here
    if status != 0:
        sys.exit(f"startup_report: {' '.join(map(str, args))} failed")
    return time.perf_counter() - start, usage.ru_maxrss / 1024, status


def paired(csw_args, cv_args, repeat, csw_env):
    """csw and OpenCV alternately; csw_env() gives each csw run's environment."""
    rows = {"csw": [], "cv": [], "ratio": [], "csw_mb": [], "cv_mb": []}
    for _ in range(repeat):
        t, mb, _ = run(csw_args, csw_env())
        u, mb2, _ = run(cv_args)
        rows["csw"].append(t)
        rows["cv"].append(u)
        rows["ratio"].append(t / u)
        rows["csw_mb"].append(mb)
        rows["cv_mb"].append(mb2)
    return rows


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--output", type=Path)
    parser.add_argument("--repeat", type=int, default=7)
    parser.add_argument("--cold-repeat", type=int, default=3)
    args = parser.parse_args()
    work = Path(tempfile.mkdtemp(prefix="csw-startup-"))
    opencv = work / "opencv_match.py"
    opencv.write_text(OPENCV_SCRIPT)
    data = Path(os.environ.get("CSW_DATA_DIR") or
                Path(__file__).resolve().parents[2] / "shared" / "datasets")
    subprocess.run([*CSW, "synth", str(work / "s1080"), "--size", "1920x1080", "--dmax",
                    "255", "--seed", "7"], check=True, stderr=subprocess.DEVNULL)
    pairs = {"tsukuba (384x288, d 0..15)": (data / "tsukuba/scene1.row3.col3.ppm",
                                            data / "tsukuba/scene1.row3.col4.ppm", 15),
             "synthetic 1920x1080, d 0..255": (work / "s1080/left.png",
                                               work / "s1080/right.png", 255)}
    warm_cache = work / "warm-cache"
    caches = iter(range(10**6))

    def cold_env():
        return dict(os.environ, CSW_KERNEL_CACHE=str(work / f"cold-{next(caches)}"))

    def warm_env():
        return dict(os.environ, CSW_KERNEL_CACHE=str(warm_cache))

    date = now_utc()
    table = []  # (pair, preset, cache, {csw, cv, ratio, csw_mb, cv_mb: [figures]})
    for name, (left, right, dmax) in pairs.items():
        cv_args = [sys.executable, str(opencv), str(left), str(right),
                   str(work / "cv.pfm"), str(dmax)]
        for preset in ("sgm", "accurate", "raw", "paper"):
            if preset == "paper" and dmax > 64:
                continue  # the window engine's full sums take minutes at 1080p
            csw_args = [*CSW, "match", str(left), str(right), "-o", str(work / "d.pfm"),
                        "--dmax", str(dmax), "--threads", "1", "--preset", preset]
            print(f"startup: {name} {preset}", file=sys.stderr, flush=True)
            cold = paired(csw_args, cv_args, args.cold_repeat, cold_env)
            run(csw_args, warm_env())  # fill the warm cache
            warm = paired(csw_args, cv_args, args.repeat, warm_env)
            table += [(name, preset, "cold", cold), (name, preset, "warm", warm)]

    # Processes that start together on one empty cache: one compiles, the others wait.
    left, right, dmax = pairs["tsukuba (384x288, d 0..15)"]
    print("startup: concurrent cold starts", file=sys.stderr, flush=True)
    single = [run([*CSW, "match", str(left), str(right), "-o", str(work / "one.pfm"),
                   "--dmax", "15", "--threads", "1"], cold_env())[0]
              for _ in range(args.cold_repeat)]
    shared = dict(os.environ, CSW_KERNEL_CACHE=str(work / "together"))
    start = time.perf_counter()
    procs = [subprocess.Popen([*CSW, "match", str(left), str(right), "-o",
                               str(work / f"c{i}.pfm"), "--dmax", "15", "--threads", "1"],
                              env=shared, stderr=subprocess.DEVNULL) for i in range(4)]
    ends = []
    for proc in procs:
        proc.wait()
        ends.append(time.perf_counter() - start)
    same = len({(work / f"c{i}.pfm").read_bytes() for i in range(4)}) == 1

    # A CI job: with and without a kept cache; and what csw compile costs once.
    print("startup: csw compile", file=sys.stderr, flush=True)
    compiled = [run([*CSW, "compile"], cold_env())[0] for _ in range(1)]

    # The library call itself, in process: csw.match against the bare kernel.
    print("startup: library overhead", file=sys.stderr, flush=True)
    text = markdown(dict(date=date, cpu=cpu_name(), cores=os.cpu_count(), table=table,
                         single=single, ends=ends, same=same, compile_seconds=compiled[0],
                         library_ms=library_overhead(pairs), imports=imports()))
    print(text)
    if args.output:
        args.output.write_text(text)


def markdown(figures):
    """The report's text (scripts/templates/startup.md) from its figures: main()'s
    measurements, each a list of seconds (or MB) over the runs."""
    f = figures

    def gap(values, digits=2):  # min/median/max with no spaces, as this report writes them
        return spread(values, digits, sep="/")

    presets = ["| pair | preset | cache | csw (s) | OpenCV script (s) | csw / OpenCV | "
               "csw peak MB | OpenCV peak MB |", "|---|---|---|---|---|---|---|---|"]
    presets += [f"| {name} | {preset} | {label} | {gap(rows['csw'])} | "
                f"{gap(rows['cv'])} | {gap(rows['ratio'])} | "
                f"{gap(rows['csw_mb'], 0)} | {gap(rows['cv_mb'], 0)} |"
                for name, preset, label, rows in f["table"]]
    imports = ["| process | seconds (min/median/max of 7) |", "|---|---|"]
    imports += [f"| {process} | {gap(seconds)} |" for process, seconds in f["imports"]]
    return fill_template("startup", [("report", dict(
        date=f["date"], cpu=f["cpu"], cores=f["cores"], preset_table="\n".join(presets),
        single=gap(f["single"]), cold_repeat=len(f["single"]),
        ends=", ".join(f"{t:.2f}" for t in sorted(f["ends"])),
        slowest=max(f["ends"]) / statistics.median(f["single"]),
        maps="identical maps" if f["same"] else "DIFFERENT MAPS",
        compile_seconds=f["compile_seconds"], library_ms=gap(f["library_ms"], 3),
        import_table="\n".join(imports)))])


def library_overhead(pairs):
    """Milliseconds of csw.match on arrays beyond its kernels' own calls, warm, one
    thread, the default preset: 200 runs."""
    import csw
    from csw.io import read_image

    left, right, _ = pairs["tsukuba (384x288, d 0..15)"]
    left, right = read_image(left), read_image(right)
    for _ in range(5):
        csw.match(left, right, dmax=15, threads=1)
    outside, _ = outside_kernels(lambda: csw.match(left, right, dmax=15, threads=1), 200)
    return outside


def imports():
    """[(process, seconds of 7 runs)]: what importing costs a fresh process."""
    codes = {"import numpy": "",
             "import csw": "",
             "import csw; csw.match": "",
             "import numba": " (not imported by a warm run)"}
    return [(f"`python -c '{code}'`{note}",
             [run([sys.executable, "-c", code])[0] for _ in range(7)])
            for code, note in codes.items()]


if __name__ == "__main__":
    np.seterr(all="ignore")
    main()
