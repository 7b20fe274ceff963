"""Robot logs, measured: reading and decoding a 640x480 stereo frame from an MCAP log
(rectified topics as they are, and raw ones rectified with the rig from their
CameraInfo), a 300-frame log through csw.match_log (what csw match LOG runs, its maps
written) against csw.Matcher.stream on the same frames held in memory, and memory over a
10,000-frame log.  Writes reports/logs.md (make bench-logs).  The logs are built from
the synthetic scene in a temporary folder and removed."""

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import csw
from csw.data.synth import render
from csw.robot.bags import BagWriter, image_message
from csw.robot.logs import read_log
from csw.scale.stream import match_log

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "scripts"))
from report_common import cpu_name, fill_template, now_utc  # noqa: E402

WIDTH, HEIGHT, DMAX = 640, 480, 63
DISTINCT = 12  # frames rendered, repeated through the log
STAMP0, PERIOD = 1_700_000_000_000_000_000, 33_333_333
MEMORY_FRAMES = 10_000


def scenes(width, height, dmax, count=DISTINCT):
    return [render(width, height, dmax, seed=7, phase=i / count)[:2] for i in range(count)]


def toy_rig(width, height):
    """A rig with mild distortion, and its rectification: R1, R2, P1, P2."""
    from csw.camera.rectification import stereo_rectify
    from csw.camera.rig import Rig

    k = np.array([[500.0, 0, width / 2], [0, 500.0, height / 2], [0, 0, 1]])
    d = np.array([-0.05, 0.01, 0, 0, 0])
    rig = Rig(k, d, k, d, np.eye(3), np.array([-0.12, 0, 0]), (width, height))
    r1, r2, p1, p2, _ = stereo_rectify(k, d, k, d, rig.size, np.eye(3), rig.t, alpha=0.0)
    return rig, (r1, r2, p1, p2)


def write_log(path, pairs, count, image="image_rect", rig=None):
    """An MCAP (or other) log of ``count`` frames cycling through ``pairs``, mono8, on
    /stereo/left|right/IMAGE, with CameraInfo beside each when ``rig`` is given."""
    writer = BagWriter(path)
    rect = toy_rig(*pairs[0][0].shape[::-1])[1] if rig is not None else None
    for index in range(count):
        stamp = STAMP0 + index * PERIOD
        for side, which in (("left", 0), ("right", 1)):
            header = writer.header(stamp, f"{side}_optical")
            writer.write(f"/stereo/{side}/{image}", stamp,
                         image_message(writer, header, pairs[index % len(pairs)][which]))
            if rig is not None:
                k, d = (rig.k1, rig.d1) if which == 0 else (rig.k2, rig.d2)
                info = writer.message(
                    "sensor_msgs/msg/CameraInfo", header=header, height=rig.size[1],
                    width=rig.size[0], distortion_model="plumb_bob", d=d.ravel(),
                    k=k.ravel(), r=rect[which].ravel(), p=rect[2 + which].ravel(),
                    binning_x=0, binning_y=0,
                    roi=writer.message("sensor_msgs/msg/RegionOfInterest", x_offset=0,
                                       y_offset=0, height=0, width=0, do_rectify=False))
                writer.write(f"/stereo/{side}/camera_info", stamp, info)
    writer.close()
    return path


def read_ms(path, rounds):
    """Milliseconds a stereo frame to read, decode (and rectify, for raw topics): the
    median of ``rounds`` passes over the whole log, its first pass over the stamps
    included."""
    times = []
    for _ in range(rounds):
        start = time.perf_counter()
        log = read_log(path)
        count = sum(1 for _ in log)
        log.close()
        times.append(1e3 * (time.perf_counter() - start) / count)
    return statistics.median(times)


def stream_against_log(folder, pairs, frames, rounds, preset):
    """Frames a second, in turns, medians: Matcher.stream on frames in memory; on the
    same frames read from an MCAP log (csw.read_log, nothing written); and match_log, what
    csw match LOG runs, its maps written; all with ``preset``."""
    path = write_log(folder / "run.mcap", pairs, frames)
    memory, streamed, whole = [], [], []
    options = dict(dmin=0, dmax=DMAX, preset=preset)
    list(csw.Matcher(**options).stream(pairs[:2]))  # warm: the kernels loaded once
    for round_ in range(rounds):
        start = time.perf_counter()  # a new Matcher each time, as match_log makes one
        for _ in csw.Matcher(**options).stream(pairs[i % len(pairs)] for i in range(frames)):
            pass
        memory.append(frames / (time.perf_counter() - start))
        start = time.perf_counter()
        log = read_log(path)
        for _ in csw.Matcher(**options).stream((left, right) for left, right, _ in log):
            pass
        log.close()
        streamed.append(frames / (time.perf_counter() - start))
        start = time.perf_counter()
        report = match_log(path, out_dir=folder / f"maps{round_}", progress=False,
                           **options)
        whole.append(frames / (time.perf_counter() - start))
        assert report["counts"]["ok"] == frames
    return statistics.median(memory), statistics.median(streamed), statistics.median(whole)


def memory_check():
    """Peak RSS at frame 1,000 and at frame 10,000 of a log, in a process of its own."""
    code = ("import json, sys; sys.path.insert(0, sys.argv[1]); import logs_report; "
            "print(json.dumps(logs_report.memory_run()))")
    out = subprocess.run([sys.executable, "-c", code, str(ROOT / "scripts")], check=True,
                         capture_output=True, text=True).stdout
    return json.loads(out.strip().splitlines()[-1])


def memory_run(frames=MEMORY_FRAMES, width=160, height=120, dmax=15):
    from stream_report import vm_hwm_mb

    with tempfile.TemporaryDirectory() as folder:
        path = write_log(Path(folder) / "long.mcap", scenes(width, height, dmax, 8), frames)
        log = read_log(path)
        peaks = {}
        start = time.perf_counter()
        pairs = ((left, right) for left, right, _ in log)
        for i, _ in enumerate(csw.Matcher(dmax=dmax).stream(pairs)):
            if i + 1 in (1_000, frames):
                peaks[i + 1] = vm_hwm_mb()
        log.close()
    return {"peaks_mb": peaks, "seconds": time.perf_counter() - start,
            "growth": peaks[frames] / peaks[1_000] - 1, "size": f"{width}x{height}"}


def live_latency(folder, frames, fps, preset):
    """``csw match - --sbs --latest`` fed a side-by-side MJPEG stream of WIDTH x HEIGHT
    views through a pipe at ``fps``: the summary's counts, the frames dropped, and each
    matched frame's latency (arrival to map written), ms."""
    import io

    import imageio.v3 as iio

    jpegs = []
    for left, right in scenes(WIDTH, HEIGHT, DMAX):
        out = io.BytesIO()
        iio.imwrite(out, np.concatenate([left, right], axis=1), extension=".jpeg")
        jpegs.append(out.getvalue())
    maps = folder / "live"
    command = [str(Path(sys.executable).parent / "csw"), "match", "-", "--sbs", "--latest",
               "--dmin", "0", "--dmax", str(DMAX), "--preset", preset, "-O", str(maps)]
    process = subprocess.Popen(command, stdin=subprocess.PIPE, stdout=subprocess.DEVNULL,
                               stderr=subprocess.DEVNULL)
    start = time.perf_counter()
    for index in range(frames):  # a camera's pace: each frame at its time, not before
        time.sleep(max(0.0, start + index / fps - time.perf_counter()))
        process.stdin.write(jpegs[index % len(jpegs)])
        process.stdin.flush()
    process.stdin.close()
    process.wait()
    summary = json.loads((maps / "summary.json").read_text())
    latencies = [entry["latency_ms"] for entry in summary["pairs"] if "latency_ms" in entry]
    return summary, latencies


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--frames", type=int, default=300)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--output", default=str(ROOT / "reports" / "logs.md"))
    parser.add_argument("--no-memory", action="store_true",
                        help="skip the 10,000-frame memory check")
    parser.add_argument("--preset", default="accurate",
                        help="the preset every stream here matches with")
    parser.add_argument("--live-frames", type=int, default=3000)
    parser.add_argument("--live-preset", default="camera",
                        help="the live stream's preset: one that keeps up at 30 frames/s")
    args = parser.parse_args()
    pairs = scenes(WIDTH, HEIGHT, DMAX)
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        rectified = write_log(folder / "rect.mcap", pairs, 100)
        raw = write_log(folder / "raw.mcap", pairs, 100, "image_raw",
                        rig=toy_rig(WIDTH, HEIGHT)[0])
        read_rect = read_ms(rectified, args.rounds)
        read_raw = read_ms(raw, args.rounds)
        memory_fps, log_fps, whole_fps = stream_against_log(folder, pairs, args.frames,
                                                            args.rounds, args.preset)
        live, latencies = live_latency(folder, args.live_frames, 30, args.live_preset)
    memory = None if args.no_memory else memory_check()
    text = markdown(dict(
        date=now_utc(), cpu=cpu_name(), rounds=args.rounds, preset=args.preset,
        frames=args.frames, read_rect=read_rect, read_raw=read_raw, memory_fps=memory_fps,
        log_fps=log_fps, whole_fps=whole_fps, memory=memory, live_preset=args.live_preset,
        live_frames=args.live_frames, live=live, latencies=latencies))
    Path(args.output).write_text(text)
    print(text)


def markdown(figures):
    """The report's text (scripts/templates/logs.md) from its figures: main()'s
    measurements; memory is None when the 10,000-frame check was skipped."""
    f = figures
    table = [
        "| what | measured | target |",
        "| --- | --- | --- |",
        f"| read + decode a {WIDTH}x{HEIGHT} stereo frame from MCAP (mono8, rectified "
        f"topics; the stamps' first pass included) | {f['read_rect']:.2f} ms | <= 2 ms |",
        f"| the same for raw topics, rectified with the rig from CameraInfo | "
        f"{f['read_raw']:.2f} ms | (rectifying is csw's remap) |",
        f"| {f['frames']} frames in memory, `csw.Matcher.stream` | {f['memory_fps']:.1f} "
        "frames/s | |",
        f"| the same frames from a {f['frames']}-frame MCAP log, `csw.read_log` into "
        f"`Matcher.stream` | {f['log_fps']:.1f} frames/s "
        f"({100 * f['log_fps'] / f['memory_fps']:.0f}%) | >= 90% |",
        f"| the same log through `csw.match_log` (`csw match LOG -O DIR`), its 1.2 MB PFM "
        f"maps and summary written | {f['whole_fps']:.1f} frames/s "
        f"({100 * f['whole_fps'] / f['memory_fps']:.0f}%) | |",
    ]
    memory = f["memory"]
    if memory is not None:
        peaks = memory["peaks_mb"]
        table.append(f"| peak RSS over a {MEMORY_FRAMES:,}-frame {memory['size']} log "
                     f"through Matcher.stream: at frame 1,000 / 10,000 | "
                     f"{peaks['1000']:.1f} / {peaks[str(MEMORY_FRAMES)]:.1f} MB "
                     f"({100 * memory['growth']:+.2f}%) | flat |")
    latencies = f["latencies"]
    latency = " and ".join(f"{statistics.median(part):.1f} ({np.percentile(part, 99):.1f}) ms"
                           for part in (latencies[:1000], latencies[-1000:]))
    return fill_template("logs", [("report", dict(
        date=f["date"], cpu=f["cpu"], rounds=f["rounds"], dmax=DMAX, preset=f["preset"],
        table="\n".join(table), live_preset=f["live_preset"], live_frames=f["live_frames"],
        width=WIDTH, height=HEIGHT, matched=f["live"]["counts"]["ok"],
        dropped=f["live"].get("dropped", 0), latency=latency, two_periods=2000 / 30))])


if __name__ == "__main__":
    main()
