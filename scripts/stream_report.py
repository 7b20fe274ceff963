"""Streams against OpenCV, measured side by side in one run: frames a second of
csw.Matcher.stream (default preset) against StereoBM at equal threads, frames side by
side against row stripes, what Matcher.match costs beyond its kernels, the RGB-to-gray
step, memory over 10,000 frames, and whole ``csw match`` processes on a side-by-side
video against a short OpenCV script (scripts/opencv_video.py).  Writes reports/stream.md
and reports/stream.json (make bench-stream)."""

import argparse
import collections
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import csw
from csw.config.params import DEFAULTS
from csw.data.synth import render
from csw.io.images import luma
from csw.matching.matcher import STREAM_STRIPES_WORK
from peers import cv2, ndisp16, stereo_bm

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "scripts"))
from report_common import cpu_name, fill_template, now_utc, outside_kernels, spread  # noqa: E402

SIZES = [(320, 240, 31), (640, 480, 63), (1242, 375, 127)]
DISTINCT = 12  # frames rendered per size, streamed over and over
DEFAULT_PRESET = DEFAULTS["preset"]  # what csw.Matcher() matches with, named in the text
ROUNDS = 5


def llvm_cpu():
    """The CPU the kernels are compiled for, as LLVM names it (znver1, znver3,
    skylake-avx512 ...): hosts that report one model name differ in vector width, which
    moves every ratio here."""
    from csw.kernels import target_cpu

    return target_cpu()


def bm_for(dmax, filters="all"):
    """StereoBM over 0..dmax: with its speckle filter and left-right check on as well
    (scripts/peers.py, BM_FILTERS: what the camera preset is measured against), or
    filters=True for its defaults."""
    return stereo_bm(ndisp16(dmax), filters=filters)


def frames_per_second(run, count):
    start = time.perf_counter()
    run()
    return count / (time.perf_counter() - start)


def drain(results):
    """Take every item of an iterable, keeping none."""
    collections.deque(results, maxlen=0)


def stream_table(repeat, **options):
    """Frames a second, csw against StereoBM with its filters, at 2 threads and at 1, in
    rounds; options: the Matcher's beside dmax and threads (none: the default preset)."""
    rows = []
    for width, height, dmax in SIZES:
        pairs = [render(width, height, dmax, seed=7, phase=i / DISTINCT)[:2]
                 for i in range(DISTINCT)]
        stream = pairs * repeat
        bm = bm_for(dmax)
        matchers = {t: csw.Matcher(dmax=dmax, threads=t, **options) for t in (1, 2)}
        for matcher in matchers.values():  # warm: kernels loaded, scratch made
            for _ in matcher.stream(pairs[:4]):
                pass
        ratios = {1: [], 2: []}
        fps = {("csw", 1): [], ("csw", 2): [], ("bm", 1): [], ("bm", 2): []}
        for _ in range(ROUNDS):
            for threads in (2, 1):
                cv2.setNumThreads(threads)
                # Each frame's result dropped as the next comes, as a camera's consumer
                # drops it (both sides): kept in a list, csw's maps (the float map and
                # the int64 costs, 0.9 MB a 320x240 frame) faulted in fresh memory at
                # every frame, a fifth of its time at that size.
                b = frames_per_second(
                    lambda: drain(bm.compute(*pair) for pair in stream),  # noqa: B023
                    len(stream))
                c = frames_per_second(
                    lambda: drain(matchers[threads].stream(stream)), len(stream))  # noqa: B023
                fps[("csw", threads)].append(c)
                fps[("bm", threads)].append(b)
                ratios[threads].append(c / b)
        for threads, target in ((2, 1.3), (1, 1.0)):
            rows.append({
                "size": f"{width}x{height}", "range": f"0..{dmax}", "threads": threads,
                "csw_fps": statistics.median(fps[("csw", threads)]),
                "bm_fps": statistics.median(fps[("bm", threads)]),
                "ratios": ratios[threads], "target": target,
                "met": min(ratios[threads]) >= target})
        print(f"streams {width}x{height} done", file=sys.stderr)
    cv2.setNumThreads(cv2.getNumberOfCPUs())
    return rows


# The camera preset built up stage by stage, accurate and the default beside it.
STAGE_STEPS = (("x-Sobel SAD 7x7 (no stage after it)",
                {"preset": "camera", "winner_check": None, "speckle_size": 0}),
               ("+ StereoBM's left-right check", {"preset": "camera", "speckle_size": 0}),
               ("+ speckles: the camera preset", {"preset": "camera"}),
               ("the camera preset with the exact left-right check",
                {"preset": "camera", "winner_check": None, "lr_check": 1}),
               ("accurate", {"preset": "accurate"}),
               (f"{DEFAULT_PRESET} (the default)", {}),
               ("raw (SAD 9x9, no stage)", {"preset": "raw"}))
PEER_STEPS = ("StereoBM default", "StereoBM + filters")


def stage_table(rounds=7):
    """Milliseconds a frame at 1 thread, the camera preset built up stage by stage, and
    the default, against StereoBM with and without its filters, called in turns: where a
    frame's time goes."""
    cv2.setNumThreads(1)
    rows = []
    for width, height, dmax in SIZES:
        pairs = [render(width, height, dmax, seed=7, phase=i / DISTINCT)[:2]
                 for i in range(4)]
        runs = {PEER_STEPS[0]: bm_for(dmax, filters=True).compute,
                PEER_STEPS[1]: bm_for(dmax).compute}
        runs.update({name: csw.Matcher(dmax=dmax, threads=1, **options).match
                     for name, options in STAGE_STEPS})
        times = {name: [] for name in runs}
        for _ in range(rounds):
            for name, run in runs.items():
                for left, right in pairs:
                    start = time.perf_counter()
                    run(left, right)
                    times[name].append((time.perf_counter() - start) * 1e3)
        rows.append({"size": f"{width}x{height}", "range": f"0..{dmax}",
                     "ms": {name: statistics.median(t) for name, t in times.items()}})
    return rows


def plan_table():
    """Frames side by side (one thread each) against one frame at a time in stripes (2
    threads), for the sizes around the switch."""
    rows = []
    for width, height, dmax, count in ((640, 480, 63, 24), (1242, 375, 127, 16),
                                       (1920, 1080, 255, 6)):
        pairs = [render(width, height, dmax, seed=7, phase=i / count)[:2]
                 for i in range(min(count, 4))]
        stream = (pairs * count)[:count]
        matcher = csw.Matcher(dmax=dmax, threads=2)
        list(matcher.stream(pairs[:2]))
        side, stripes, latency_side, latency_stripes = [], [], [], []
        for _ in range(3):
            for in_flight, into, lat in ((2, side, latency_side), (1, stripes,
                                                                   latency_stripes)):
                start = time.perf_counter()
                results = list(matcher.stream(stream, in_flight=in_flight))
                into.append(count / (time.perf_counter() - start))
                lat.append(statistics.median(r.seconds for r in results) * 1e3)
        work = width * height * (dmax + 1)
        rows.append({"size": f"{width}x{height}", "range": f"0..{dmax}",
                     "work_M": work / 1e6, "side_fps": side, "stripes_fps": stripes,
                     "side_ms": statistics.median(latency_side),
                     "stripes_ms": statistics.median(latency_stripes),
                     "chosen": "stripes" if work > STREAM_STRIPES_WORK else "side by side"})
        print(f"plan {width}x{height} done", file=sys.stderr)
    return rows


def overhead_table(calls=300):
    """What Matcher.match costs beyond the time inside its kernel entries, on 320x240,
    per preset, and whether it equals csw.match bit for bit."""
    left, right = render(320, 240, 31, seed=7, phase=0.3)[:2]
    rows = []
    for preset in ("camera", "accurate", "raw", "paper"):
        matcher = csw.Matcher(preset=preset, dmax=31, threads=1)
        for _ in range(10):
            matcher.match(left, right)
        results = []
        outside, kernels_ms = outside_kernels(
            lambda: results.append(matcher.match(left, right)),  # noqa: B023
            calls if preset != "paper" else calls // 15)  # paper: slow
        result = results[-1]
        expected = csw.match(left, right, preset=preset, dmax=31, threads=1)
        equal = bool(np.array_equal(result.disparity, expected.disparity, equal_nan=True)
                     and np.array_equal(result.min_cost, expected.min_cost))
        rows.append({"preset": preset, "outside_ms": outside,
                     "kernels_ms": statistics.median(kernels_ms), "equal": equal})
    return rows


def gray_table():
    """The RGB-to-gray step at 1282x1110 (a Middlebury 2014 image's size): for an array
    (csw.io.images.luma, what csw.match does with an RGB array) and for a file (what
    csw.read_image does after decoding: Pillow's convert of the decoded image)."""
    from PIL import Image

    rgb = np.random.default_rng(0).integers(0, 256, (1110, 1282, 3), dtype=np.uint8)
    decoded = Image.fromarray(rgb, "RGB")
    steps = {"array_ms": lambda: luma(rgb),
             "file_ms": lambda: np.asarray(decoded.convert("L")),
             "opencv_ms": lambda: cv2.cvtColor(rgb, cv2.COLOR_RGB2GRAY)}
    times = {name: [] for name in steps}
    for step in steps.values():
        step()
    for _ in range(15):
        for name, step in steps.items():
            start = time.perf_counter()
            step()
            times[name].append((time.perf_counter() - start) * 1e3)
    return times


MEMORY_FRAMES = 10_000


def memory_check():
    """Peak RSS (VmHWM) at frame 1,000 and at frame 10,000 of one 320x240 stream, in a
    process of its own (this one's peak is the 1080p frames' above)."""
    code = ("import json, sys; sys.path.insert(0, sys.argv[1]); import stream_report; "
            "print(json.dumps(stream_report.memory_run()))")
    out = subprocess.run([sys.executable, "-c", code, str(ROOT / "scripts")], check=True,
                         capture_output=True, text=True).stdout
    return json.loads(out.strip().splitlines()[-1])


def memory_run(frames=MEMORY_FRAMES):
    pairs = [render(320, 240, 31, seed=7, phase=i / 8)[:2] for i in range(8)]
    matcher = csw.Matcher(dmax=31, threads=2)
    peaks = {}
    start = time.perf_counter()
    for i, _ in enumerate(matcher.stream(pairs[i % 8] for i in range(frames))):
        if i + 1 in (1_000, frames):
            peaks[i + 1] = vm_hwm_mb()
    return {"peaks_mb": peaks, "seconds": time.perf_counter() - start,
            "growth": peaks[frames] / peaks[1_000] - 1}


def vm_hwm_mb():
    with open("/proc/self/status") as status:
        for line in status:
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) / 1024
    return float("nan")


WHOLE_PRESETS = ("camera", "accurate")
WHOLE_TARGETS = {"camera": 1.2, "accurate": 1.0}


def whole_process(folder, rounds=3, frames=300):
    """``csw match`` on a side-by-side 640x480 video, writing a map per frame and the
    preview video, with each of WHOLE_PRESETS, against the OpenCV script doing the same
    (without the maps), run in turns; wall seconds of whole processes."""
    video = sbs_video(folder, frames)
    commands = {preset: [sys.executable, "-c", "from csw_cli.main import main; main()",
                         "match", str(video), "--sbs", "--dmax", "63", "--preset", preset,
                         "--output-dir", str(folder / f"maps-{preset}"), "--overwrite",
                         "--preview-video", str(folder / f"{preset}.mp4")]
                for preset in WHOLE_PRESETS}
    commands["opencv"] = [sys.executable, str(ROOT / "scripts" / "opencv_video.py"),
                          str(video), str(folder / "opencv.mp4"), "64"]
    # Bytecode written once, by the warm-up, into the report's own folder: as an
    # installed package has it (pip compiles it), where a checkout run with
    # PYTHONDONTWRITEBYTECODE compiled csw's 70 modules again in every process (0.1-0.3 s).
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    env["PYTHONPYCACHEPREFIX"] = str(folder / "pycache")
    for command in commands.values():  # warm: kernels cached
        subprocess.run(command, check=True, capture_output=True, env=env)
    walls = {name: [] for name in commands}
    cpus = {name: [] for name in commands}  # the child's user + system seconds
    for _ in range(rounds):
        for name, command in commands.items():
            (folder / f"{name}.mp4").unlink(missing_ok=True)
            before = resource.getrusage(resource.RUSAGE_CHILDREN)
            start = time.perf_counter()
            subprocess.run(command, check=True, capture_output=True, env=env)
            walls[name].append(time.perf_counter() - start)
            after = resource.getrusage(resource.RUSAGE_CHILDREN)
            cpus[name].append(after.ru_utime + after.ru_stime
                              - before.ru_utime - before.ru_stime)
    ratios = {preset: [o / c for c, o in zip(walls[preset], walls["opencv"], strict=True)]
              for preset in WHOLE_PRESETS}
    return {"frames": frames, "walls": walls, "cpus": cpus, "ratios": ratios}


def sbs_video(folder, frames=300):
    """The 640x480 side-by-side H.264 video of the moving scene (30 distinct frames)."""
    from csw.io.video import write_video

    video = folder / "sbs.mp4"
    if not video.exists():
        distinct = [np.concatenate(render(640, 480, 63, seed=7, phase=i / 30)[:2], axis=1)
                    for i in range(30)]
        write_video(video, (distinct[i % 30] for i in range(frames)), quality=12)
    return video


class Laps:
    """Seconds spent in each named step: ``lap(step)`` charges the time since the last
    lap (or restart) to ``step``."""

    def __init__(self, steps):
        self.seconds = dict.fromkeys(steps, 0.0)
        self.restart()

    def restart(self):
        self.clock = time.perf_counter()

    def __call__(self, step):
        now = time.perf_counter()
        self.seconds[step] += now - self.clock
        self.clock = now


SPLIT_STEPS = ("decoding to gray", "matching", "colour map", "preview encoding",
               "map writing")


def frame_split(folder, frames=150):
    """Milliseconds a frame of each step of a video run, in one thread, one step after
    another (the run itself overlaps them: csw.scale.stream), per preset, over the first
    ``frames`` frames of the side-by-side video; and the matching alone as a stream
    (Matcher.stream on the decoded frames, 2 threads): the frames a second the whole run
    is bound by."""
    from csw.io.formats import write_disparity
    from csw.io.pictures import DisparityColours
    from csw.io.video import VideoReader, VideoWriter

    video = sbs_video(folder)
    out = {}
    for preset in WHOLE_PRESETS:
        matcher = csw.Matcher(dmax=63, threads=1, preset=preset)
        colours, pairs = DisparityColours(), []
        writer = VideoWriter(folder / f"split-{preset}.mp4", 30.0)
        lap = Laps(SPLIT_STEPS)
        count = 0
        for index, gray, _ in VideoReader(video):
            lap("decoding to gray")
            half = gray.shape[1] // 2
            left, right = gray[:, :half], gray[:, half:]
            result = matcher.match(left, right)
            lap("matching")
            picture = colours(result.disparity, 0, 63)
            lap("colour map")
            writer.write(picture)
            lap("preview encoding")
            write_disparity(folder / f"split-{index:06d}.pfm", result.disparity)
            lap("map writing")
            pairs.append((left, right))
            count += 1
            if count == frames:
                break
            lap.restart()
        writer.close()
        stream = csw.Matcher(dmax=63, threads=2, preset=preset)
        list(stream.stream(pairs[:4]))
        start = time.perf_counter()
        drain(stream.stream(pairs))
        out[preset] = {"ms": {k: 1e3 * v / count for k, v in lap.seconds.items()},
                       "matching_fps": count / (time.perf_counter() - start)}
    return out


def stream_rows(rows, target, met):
    """The lines of a frames-a-second table (stream_table's rows); target, met: the
    headers of its last two columns."""
    out = ["| frames | d | threads | csw frames/s | StereoBM frames/s | csw / BM: min / "
           f"median / max | {target} | {met} |", "|---|---|---|---|---|---|---|---|"]
    for row in rows:
        out.append(f"| {row['size']} | {row['range']} | {row['threads']} | "
                   f"{row['csw_fps']:.0f} | {row['bm_fps']:.0f} | {spread(row['ratios'])} | "
                   f"≥ {row['target']} | {'yes' if row['met'] else 'no'} |")
    return lines(out)


def markdown(data):
    """The report's text: scripts/templates/stream.md, filled in from the figures."""
    llvm = (f" (LLVM's name for it: {data['llvm_cpu']}; the kernels are compiled for it)"
            if data.get("llvm_cpu") else "")
    default = data.get("default_preset", DEFAULT_PRESET)
    blocks = [("head", dict(date=data["date"], cpu=data["cpu"], llvm=llvm,
                            cores=data["cores"], opencv=cv2.__version__, distinct=DISTINCT,
                            table=stream_rows(data["streams"], "target",
                                              "met in every round")))]
    if data.get("streams_accurate"):
        blocks.append(("accurate", dict(default=default, table=stream_rows(
            data["streams_accurate"], "the camera's target", "at it in every round"))))
    if data.get("stages"):
        blocks.append(("stages", dict(default=default, table=stage_rows(data["stages"]))))
    blocks.append(("plan", dict(default=default, stripes_m=f"{STREAM_STRIPES_WORK / 1e6:.0f}",
                                table=lines(
        ["| frames | d | pixel-disparities (M) | side by side frames/s | stripes frames/s "
         "| latency side by side (ms) | latency stripes (ms) | csw chooses |",
         "|---|---|---|---|---|---|---|---|"] +
        [f"| {row['size']} | {row['range']} | {row['work_M']:.0f} | "
         f"{spread(row['side_fps'], 1)} | {spread(row['stripes_fps'], 1)} | "
         f"{row['side_ms']:.1f} | {row['stripes_ms']:.1f} | {row['chosen']} |"
         for row in data["plan"]]))))
    blocks.append(("overhead", dict(table=lines(
        ["| preset | kernels (ms, median) | outside them (ms): min / median / max | "
         "equal to csw.match |", "|---|---|---|---|"] +
        [f"| {row['preset']} | {row['kernels_ms']:.2f} | {spread(row['outside_ms'])} | "
         f"{'yes' if row['equal'] else 'no'} |" for row in data["overhead"]]))))
    gray = data["gray"]
    blocks.append(("gray", dict(array=spread(gray["array_ms"]), file=spread(gray["file_ms"]),
                                opencv=spread(gray["opencv_ms"]))))
    memory = data["memory"]
    if memory:
        blocks.append(("memory", dict(default=default, at_1000=memory["peaks_mb"]["1000"],
                                      at_10000=memory["peaks_mb"]["10000"],
                                      growth=100 * memory["growth"],
                                      seconds=memory["seconds"])))
    whole = data["whole"]
    if whole:
        blocks.append(("whole", dict(frames=whole["frames"], table=whole_rows(whole))))
    if data.get("split"):
        blocks.append(("split", dict(table=split_rows(data["split"], whole))))
    blocks.append(("notes", dict(notes=lines(data["notes"]))))
    return fill_template("stream", blocks)


def lines(rows):
    return "\n".join(rows)


def stage_rows(stages):
    names = [name for name, _ in STAGE_STEPS]
    out = ["| frames | d | " + " | ".join(PEER_STEPS + tuple(names)) + " |",
           "|---|---|" + "---|" * (len(names) + len(PEER_STEPS))]
    for row in stages:
        bm = row["ms"][PEER_STEPS[1]]
        out.append(f"| {row['size']} | {row['range']} | " + " | ".join(
            f"{row['ms'][name]:.1f} ({row['ms'][name] / bm:.2f}x)"
            for name in PEER_STEPS + tuple(names)) + " |")
    return lines(out)


def whole_rows(whole):
    fps = {name: [whole["frames"] / w for w in walls] for name, walls in whole["walls"].items()}
    cpus = whole.get("cpus")  # figures from before it kept CPU seconds: no such column
    out = ["| | wall (s) | " + ("CPU, all threads (s) | " if cpus else "")
           + "frames/s | csw / OpenCV frames/s | target |",
           "|---|---|" + ("---|" if cpus else "") + "---|---|---|"]
    for name in whole["walls"]:
        ratio = whole["ratios"].get(name)
        target = WHOLE_TARGETS.get(name)
        out.append(f"| {'OpenCV script' if name == 'opencv' else 'csw ' + name} | "
                   f"{spread(whole['walls'][name])} | "
                   + (f"{spread(cpus[name])} | " if cpus else "")
                   + f"{spread(fps[name], 1)} | "
                   + (f"{spread(ratio)} | ≥ {target} |" if ratio else " | |"))
    return lines(out)


def split_rows(split, whole):
    out = ["| preset | " + " | ".join(SPLIT_STEPS) + " | matching alone, 2 threads "
           "(frames/s) | whole run (frames/s, median) |",
           "|---|" + "---|" * (len(SPLIT_STEPS) + 2)]
    for preset, row in split.items():
        run = statistics.median(whole["frames"] / w for w in whole["walls"][preset]) \
            if whole else float("nan")
        out.append(f"| {preset} | " + " | ".join(f"{row['ms'][k]:.2f}" for k in SPLIT_STEPS)
                   + f" | {row['matching_fps']:.1f} | {run:.1f} |")
    return lines(out)


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--output", default=str(ROOT / "reports" / "stream.md"))
    parser.add_argument("--repeat", type=int, default=4,
                        help="times each size's distinct frames are streamed per round")
    parser.add_argument("--quick", action="store_true",
                        help="skip the 10,000-frame memory check and the whole processes")
    parser.add_argument("--from-json", help="rewrite the report from a stream.json")
    args = parser.parse_args()
    if args.from_json:  # the figures kept, the text regenerated
        data = json.loads(Path(args.from_json).read_text())
        data["notes"] = notes(data)
        Path(args.output).write_text(markdown(data))
        return
    data = {"date": now_utc(), "cpu": cpu_name(), "llvm_cpu": llvm_cpu(),
            "cores": os.cpu_count(), "default_preset": DEFAULT_PRESET}
    data["streams"] = stream_table(args.repeat, preset="camera")
    data["streams_accurate"] = stream_table(args.repeat, preset="accurate")
    data["plan"] = plan_table()
    data["stages"] = stage_table()
    data["overhead"] = overhead_table()
    data["gray"] = gray_table()
    data["memory"] = None if args.quick else memory_check()
    with tempfile.TemporaryDirectory() as folder:
        data["whole"] = None if args.quick else whole_process(Path(folder))
        data["split"] = frame_split(Path(folder))
    data["notes"] = notes(data)
    Path(args.output).write_text(markdown(data))
    Path(args.output).with_suffix(".json").write_text(json.dumps(data, indent=1,
                                                                 default=str) + "\n")
    print(f"wrote {args.output}", file=sys.stderr)


def notes(data):
    """Plain sentences on the targets met and missed, from the figures."""
    lines = []
    missed = [r for r in data["streams"] if not r["met"]]
    if missed:
        worst = min(missed, key=lambda r: statistics.median(r["ratios"]))
        lines.append(
            f"- Frames a second, camera preset: {len(missed)} of {len(data['streams'])} "
            f"rows miss their target in some round; the furthest is {worst['size']} at "
            f"{worst['threads']} thread(s), {statistics.median(worst['ratios']):.2f}x "
            "StereoBM + filters (median).")
    else:
        lines.append("- Frames a second, camera preset: every row meets its target in "
                     "every round.")
    if data.get("streams_accurate"):
        rows = data["streams_accurate"]
        lines.append(
            f"- The accurate preset streams at "
            f"{min(statistics.median(r['ratios']) for r in rows):.2f}-"
            f"{max(statistics.median(r['ratios']) for r in rows):.2f}x StereoBM + "
            "filters' frames a second (medians).")
    for row in data.get("stages") or []:
        bm = row["ms"][PEER_STEPS[1]]
        ms = {name: row["ms"][name] / bm for name, _ in STAGE_STEPS}
        steps = [name for name, _ in STAGE_STEPS]
        lines.append(
            f"- At {row['size']}, one thread, against StereoBM + filters: x-Sobel SAD "
            f"takes {ms[steps[0]]:.2f}x its time, StereoBM's left-right check brings it to "
            f"{ms[steps[1]]:.2f}x and the speckle filter to {ms[steps[2]]:.2f}x, the camera "
            f"preset (with the exact check: {ms[steps[3]]:.2f}x; accurate: "
            f"{ms[steps[4]]:.2f}x; {steps[5]}: {ms[steps[5]]:.2f}x; StereoBM's filters cost it "
            f"{bm / row['ms'][PEER_STEPS[0]]:.2f}x its defaults' time).")
    by_size = {}
    for row in data["streams"]:
        by_size.setdefault(row["size"], {})[row["threads"]] = row
    for size, rows in by_size.items():
        if 1 in rows and 2 in rows:
            gain = rows[2]["bm_fps"] / rows[1]["bm_fps"]
            # Frames side by side at best double csw's one-thread rate.
            need = 2 / (rows[2]["target"] * gain)
            now = 1 / statistics.median(rows[1]["ratios"])
            lines.append(
                f"- Two threads at {size}: StereoBM gains {gain:.2f}x from its second "
                f"thread, frames side by side at most 2x; reaching {rows[2]['target']}x "
                f"needs csw's one-thread time at most {need:.2f}x StereoBM's (it is "
                f"{now:.2f}x).")
    medians = {r["preset"]: statistics.median(r["outside_ms"]) for r in data["overhead"]}
    kernels_ms = {r["preset"]: r["kernels_ms"] for r in data["overhead"]}
    fast = max(v for k, v in medians.items() if k != "paper")
    lines.append(f"- Beyond its kernels a 320x240 match costs up to {fast:.2f} ms (median) "
                 "with the presets a stream uses (camera, accurate, raw): " +
                 ("the target of 0.2 ms is met." if fast <= 0.2 else
                  "the target of 0.2 ms is not met.") +
                 (f"  The paper preset's {medians['paper']:.2f} ms is the hand-over to the "
                  "pool thread its window engine runs in, beside kernels of "
                  f"{kernels_ms.get('paper', 0):.0f} ms."
                  if "paper" in medians else ""))
    gray = statistics.median(data["gray"]["array_ms"])
    lines.append(f"- RGB to gray at 1282x1110: an RGB array takes {gray:.2f} ms (median) in "
                 "csw's colour kernel, against the target of 3 ms: " +
                 ("met." if gray <= 3 else "not met."))
    for preset, row in (data.get("split") or {}).items():
        total = sum(row["ms"].values())
        others = total - row["ms"]["matching"]
        cores = data["cores"]
        lines.append(
            f"- A video frame's steps, {preset} preset, take {total:.1f} ms of one core, "
            f"{others:.1f} of them beside the matching (decoding, colours, encoding, the "
            f"map's file): on {cores} cores that caps a run at about "
            f"{1000 * cores / total:.0f} frames a second however well they overlap, below "
            f"the {row['matching_fps']:.0f} of the matching alone; a run is bound by the "
            "matching alone only where a core is free for the rest.")
    if data["whole"] and data["whole"].get("cpus"):
        for preset in WHOLE_PRESETS:
            cpu = statistics.median(data["whole"]["cpus"][preset])
            wall = statistics.median(data["whole"]["walls"][preset])
            lines.append(f"- Whole process, {preset} preset: {cpu:.1f} s of CPU over its "
                         f"threads (median), {cpu / data['cores']:.2f} s on {data['cores']} "
                         f"cores at best, against a wall time of {wall:.2f} s: the rest is "
                         "start-up and waiting.")
    if data["whole"]:
        for preset, ratios in data["whole"]["ratios"].items():
            ratio, target = statistics.median(ratios), WHOLE_TARGETS[preset]
            lines.append(f"- Whole processes on video, {preset} preset: csw runs at "
                         f"{spread(ratios)}x the OpenCV script's frames a second (min / "
                         f"median / max), target {target}x: "
                         + ("met in every round." if min(ratios) >= target else
                            "met at the median." if ratio >= target else "not met."))
    return lines


if __name__ == "__main__":
    main()
