"""``csw match``: one rectified pair in, one disparity map out.  The command takes every
mode's options and sends many pairs to match_many.py, videos, live sources and robot
logs to match_frames.py."""

import os

import click

from csw.io.formats import map_formats_text, suffixes

from .. import options as opt
from .match_frames import LOG_ONLY, log_mode, video_mode
from .match_many import many_mode

# The matching options csw match passes on when given (the library fills in the rest).
MATCH_OPTIONS = ["preset", "engine", "cost", "window", "dmin", "dmax", "csw", "csw_rule",
                 "tau", "csw_margin", "threads", *opt.params.OFF]


def summary_line(result):
    """The one line ``csw match`` prints on stderr about a match."""
    from csw.config.tau import tau_label
    from csw.matching.narrow import narrows

    s = result.settings
    height, width = result.shape
    tau_note = " (auto)" if s["tau_source"] == "auto" else ""
    mode = (f"CSW {s['csw_rule']} tau={tau_label(s['tau'])}{tau_note}" if s["csw"]
            else "plain")
    engine = f"{s['engine']} engine"
    if s.get("aggregate") == "sgm":
        mode = f"SGM {s['sgm_paths']} paths P1 {s['sgm_p1']} P2 {s['sgm_p2']}"
        if narrows(s.get("sgm_narrow", 0), s["dmin"], s["dmax"], width):
            mode += f", {s['sgm_narrow']} disparities a pixel after a half-size pass"
        engine = "semi-global"
    stripes = f", {result.stripes} stripe(s)" if result.stripes else ""
    notes = ""
    source = s.get("range_source")
    if source and source.startswith("auto"):
        notes += (f"; range found from the {'first ' if 'first' in source else ''}pair "
                  "(--dmin/--dmax fix it)")
    elif source not in (None, "given", "default"):
        notes += f"; range from {source}"
    if s.get("calibration"):
        notes += f"; calibration {s['calibration']}"
    cost = s["cost"].upper()
    if s["cost"] == "census":  # which codes: the census window is not the matching one
        cost += f" ({s['census_pattern']} {s['census_window']}x{s['census_window']} codes)"
    return (f"{width}x{height} d {s['dmin']}..{s['dmax']} {cost} "
            f"{s['window']}x{s['window']} {mode}, preset {s['preset']} "
            f"({engine}{stripes}): "
            f"{result.seconds:.3f} s (compile {result.compile_seconds:.2f} s), evaluated "
            f"{100.0 * result.evaluated / max(result.candidates, 1):.1f}% of candidates, "
            f"invalid {100.0 * result.invalid_share:.1f}%{notes}")


def memory_size(ctx, param, value):
    from csw.scale.tiled import parse_size

    if value is None:
        return None
    try:
        size = parse_size(value)
    except ValueError as exc:
        raise click.BadParameter(str(exc)) from None
    if size <= 0:
        raise click.BadParameter("must be more than 0")
    return size


# --help in the order a user reads it: what to match and where to write it, the range,
# the preset and its stages, CSW, 3-D outputs, many pairs and clusters, the engine.
MATCH_HELP = opt.sectioned(
    ("Output", ["output", "preview", "confidence", "cost_map"]),
    ("Disparity range", ["dmin", "dmax"]),
    ("Preset and matching cost", ["preset", "cost", "window", "census_window",
                                  "census_pattern"]),
    ("Semi-global matching", ["aggregate", "sgm_paths", "sgm_p1", "sgm_p2", "sgm_narrow"]),
    ("Pipeline stages (on top of the preset)",
     ["prefilter", "prefilter_cap", "texture_threshold", "lr_check", "winner_check",
      "uniqueness_ratio", "subpixel", "speckle_size", "speckle_range", "median", "fill"]),
    ("Depth and point clouds", ["depth", "depth_preview", "cloud", "max_depth", "calib",
                                "focal", "baseline", "cx", "cy", "doffs", "units",
                                "calib_units"]),
    ("Raw pairs from a calibrated rig", ["rigs", "alpha", "rectified_left", "frame"]),
    ("Video and live sources", ["sbs", "preview_video", "preview_sbs", "range_each_frame",
                                "latest"]),
    ("Robot logs (ROS 1/2 bags, MCAP, KITTI raw drives)",
     ["left_topic", "right_topic", "stamp_tolerance", "bag_out", "bag_depth"]),
    ("Many pairs, big pairs and clusters", ["output_dir", "manifest", "suffix",
                                            "overwrite", "summary", "memory_limit",
                                            "workers", "scheduler"]),
    # Off by default, and no faster on the default engine: after what most runs use.
    ("CSW: skip right pixels already claimed", ["csw", "csw_rule", "tau", "csw_margin"]),
    ("Engine", ["engine", "threads"]),
)


@click.command(cls=MATCH_HELP)
@click.argument("left", type=click.Path(), required=False)
@click.argument("right", type=click.Path(), required=False)
@click.option("--output", "-o", type=click.Path(),
              help=f"Disparity map: {map_formats_text()}.")
@click.option("--manifest", type=click.Path(dir_okay=False, exists=True),
              help="Many pairs: a CSV file of left,right[,name] lines (paths relative to "
                   "it). Needs --output-dir.")
@click.option("--output-dir", "-O", type=click.Path(file_okay=False),
              help="Many pairs: the folder for their maps (NAME.pfm ...) and summary.json, "
                   "created if missing. LEFT and RIGHT may then be folders, paired by file "
                   "name.")
@click.option("--suffix", type=click.Choice(suffixes("whole")), default=".pfm",
              show_default=True, help="Many pairs: the format of each map.")
@click.option("--overwrite/--skip-existing", default=False, show_default=True,
              help="Many pairs: redo pairs whose map exists (default: skip them, so a rerun "
                   "resumes).")
@click.option("--summary", type=click.Path(dir_okay=False),
              help="Many pairs: where to write the JSON summary [default: "
                   "OUTPUT_DIR/summary.json].")
@click.option("--workers", type=click.IntRange(1, 256), default=None,
              help="Run the pairs (or one pair's stripes) on a Dask cluster of N worker "
                   "processes started on this machine (needs csw[dask]).")
@click.option("--scheduler", default=None,
              help="Run the pairs (or one pair's stripes) on the existing Dask cluster at "
                   "this address, e.g. tcp://10.0.0.5:8786; its workers must reach the "
                   "input and output folders.")
@click.option("--memory-limit", callback=memory_size, default=None,
              help="One pair, in row stripes that fit this much memory per process "
                   "(e.g. 512MB, 2GiB; the process adds about 200 MB). Pairs too big for "
                   "the default, 512MiB, are striped without asking.")
@opt.option("engine")
@opt.option("cost")
@opt.option("window", short="-w")
@opt.option("dmin")
@opt.option("dmax", help=opt.params.OPTIONS["dmax"].help + " [default: the ndisp of a "
                         "calib.txt beside LEFT (or --calib's), else auto; the paper "
                         f"preset: {opt.params.FIXED_DMAX}]")
@opt.option("csw")
@opt.option("csw_rule")
@opt.option("tau")
@opt.option("csw_margin")
@opt.option("threads", short="-j")
@click.option("--preview", type=click.Path(dir_okay=False),
              help="Also write a colour PNG of the map (Turbo, invalid black) over a colour "
                   "bar of its values. Many pairs, a video's or a log's frames: .png, for "
                   "NAME.preview.png beside each map.")
@click.option("--cost-map", type=click.Path(dir_okay=False),
              help="Also write the minimum-cost map m as PFM (inf where invalid).")
@click.option("--confidence", type=click.Path(dir_okay=False),
              help="Also write the confidence (0..1: how much the best cost beats the "
                   "second best) as PFM (or .npy, .tif, .zarr). Many pairs, frames: the "
                   "format, e.g. .pfm: NAME.confidence.pfm.")
@opt.calibration_options(beside_left=True)
@click.option("--depth", type=click.Path(dir_okay=False),
              help=f"Also write the depth map ({', '.join(suffixes('depth'))}), from the "
                   "calibration. Many pairs: the format, e.g. .pfm: NAME.depth.pfm beside "
                   "each map.")
@click.option("--cloud", type=click.Path(dir_okay=False),
              help="Also write the point cloud (binary PLY, coloured from LEFT). Many "
                   "pairs: .ply, for NAME.ply beside each map.")
@click.option("--depth-preview", type=click.Path(dir_okay=False),
              help="Also write a colour PNG of the depth. Many pairs: .png, for "
                   "NAME.depth.png.")
@click.option("--max-depth", type=click.FloatRange(min=0, min_open=True),
              help="Leave points farther than this out of the cloud.")
@click.option("--rig", "rigs", multiple=True, type=click.Path(dir_okay=False, exists=True),
              help="LEFT and RIGHT are raw images of this calibrated rig: rectify them "
                   "first (OpenCV YAML/XML, ROS camera_info left then right, KITTI "
                   "calib_cam_to_cam.txt, Kalibr camchain; repeat for two files). The "
                   "map is on the rectified left image's grid; the rig gives depth and "
                   "clouds their calibration. A log: replaces its camera_info.")
@click.option("--alpha", type=click.FloatRange(-1, 1), default=0.0, show_default=True,
              help="With --rig: 0 keeps only pixels with a source (no black border), 1 "
                   "every raw pixel.")
@click.option("--rectified-left", type=click.Path(dir_okay=False),
              help="With --rig: also write the rectified left image (PNG).")
@click.option("--frame", type=click.Choice(["rectified", "camera"]), default="rectified",
              show_default=True,
              help="With --rig: the point cloud in the rectified left camera's frame, or "
                   "back in the raw left camera's (what a robot's transform tree expects).")
@click.option("--sbs", is_flag=True,
              help="LEFT is one side-by-side video (its left half the left camera, as "
                   "ZED's and other stereo webcams give it); no RIGHT.")
@click.option("--preview-video", type=click.Path(dir_okay=False),
              help="Video: also write the colour disparity video (.mp4, .mkv, .mov or "
                   ".avi; Turbo over the range, invalid black).")
@click.option("--preview-sbs", is_flag=True,
              help="With --preview-video: the left frame beside the disparity.")
@click.option("--range-each-frame", is_flag=True,
              help="Video with a range 'auto' (the default without --dmax): find it on "
                   "every frame rather than on the first and keeping it, for a drive whose "
                   "depths change (a coarse match a frame: about a tenth more time at "
                   "640x480, twice the time at 320x240).")
@click.option("--latest", is_flag=True,
              help="A live source (- for standard input, /dev/video0 for a V4L2 camera, "
                   "with --sbs): match the newest frame, dropping those that come while "
                   "matching, rather than fall behind.")
@click.option("--left-topic", help="Log: the left image topic [default: a .../left/... "
                                   "image topic with a .../right/... twin, rectified "
                                   "ones first].")
@click.option("--right-topic", help="Log: the right image topic [default: the left's name "
                                    "with right for left].")
@click.option("--stamp-tolerance", type=click.FloatRange(0, 10, max_open=True), default=0.0,
              show_default=True,
              help="Log: seconds between a left and a right stamp that still pair (each "
                   "the other's nearest, as message_filters' approximate time); 0: "
                   "exact stamps.")
@click.option("--bag-out", type=click.Path(),
              help="Log: also write a new bag (.bag ROS 1, .mcap, else a ROS 2 bag "
                   "folder) of each frame's DisparityImage (NS/disparity) and "
                   "PointCloud2 (NS/points2), with the input's stamps and frame id.")
@click.option("--bag-depth", is_flag=True,
              help="With --bag-out: also depth images (32FC1, metres) on NS/depth.")
@opt.stage_options()
@click.pass_context
def match(ctx, left, right, output, manifest, output_dir, suffix, overwrite, summary, workers,
          scheduler, memory_limit, preview, cost_map, confidence, depth, cloud,
          depth_preview, max_depth, units, rigs, alpha, rectified_left, frame, sbs,
          preview_video, preview_sbs, range_each_frame, latest, left_topic, right_topic,
          stamp_tolerance, bag_out, bag_depth, **_):
    """Match LEFT against RIGHT (left is the reference) and write the disparity map.

    The match of left pixel x is right pixel x - d, for d in [DMIN, DMAX].  With --csw,
    each row keeps a map of right pixels already claimed by a match whose cost is at most
    TAU, and later searches on the row skip them.

    The default preset, sgm, aggregates census costs along 4 semi-global paths and leaves
    invalid the pixels the left-right check or the speckle filter refuses (add --fill
    background for a map with none); --preset raw gives the contract's dense
    winner-take-all map.  CSW (--csw) is local matching's: give it a local preset.

    \b
    Presets by the numbers (docs/pipeline.md; 4 KITTI pairs: density / filled D1;
    one thread at 640x480, d 0..63, against StereoBM with its filters' time):
      camera    50% / 9.9%   0.56x   StereoBM's stages; beats StereoBM on both
      accurate  77% / 7.0%   0.75x   census costs, local windows
      sgm       92% / 4.5%   2.6x    semi-global paths (the default)
      raw      100% / 35%    0.41x   no check: every pixel, right or wrong
      StereoBM + filters: 35% / 17.2%, 1.00x

    Many pairs: give two folders (pairs by file name) or --manifest, and --output-dir.
    A pair that fails is reported and the others go on; the exit code is 1 if any failed.

    Video: give two videos (frames paired by index) or one side-by-side video with
    --sbs, and --output-dir (a map per frame, NNNNNN.pfm) or --preview-video or both.
    Frames are matched side by side on every core, decoded ahead and written behind
    in threads of their own.  A live side-by-side source: a V4L2 camera (/dev/video0)
    or a stream on standard input (-), with --sbs, and --latest to drop frames rather
    than fall behind.

    Robot log: give one ROS 1 bag, ROS 2 bag (folder, .db3 or .mcap) or KITTI raw
    drive folder, and --output-dir and/or --bag-out.  Frames are paired by header
    stamp; raw topics are rectified with the rig from their camera_info (or --rig).

    \b
    Examples:
      csw match left.png right.png -o disp.pfm --preview view.png
      csw match left.png right.png -o disp.pfm --subpixel linear --fill background
      csw match left.png right.png -o disp.png --preset raw --csw --tau auto
      csw match lefts/ rights/ --output-dir maps/ --dmax 128
      csw match --manifest pairs.csv -O maps/ --suffix .png
      csw match lefts/ rights/ -O maps/ --workers 2
      csw match big_left.tif big_right.tif -o disp.tif --memory-limit 1GiB
      csw match raw_l.png raw_r.png --rig stereo.yml -o disp.pfm --cloud c.ply
      csw match drive.mp4 --sbs -O maps/ --preview-video view.mp4 --dmax 64
      csw match drive.mcap -O maps/ --bag-out stereo.mcap --dmax 64
      ffmpeg -i cam.mkv -f mjpeg - | csw match - --sbs -O maps/ --latest --dmax 64
    """
    from csw.io.video import is_live, is_video
    from csw.robot.logs import is_log

    settings = opt.given(ctx, MATCH_OPTIONS)
    log_only = [name for name in LOG_ONLY if ctx.get_parameter_source(name).name != "DEFAULT"]
    if left is not None and not sbs and is_log(left):
        return log_mode(ctx, left, right, output_dir, suffix, overwrite, summary, rigs,
                        alpha, preview_video, preview_sbs, range_each_frame, settings)
    if log_only:
        raise click.UsageError(f"--{log_only[0].replace('_', '-')} is for a log (a bag, "
                               ".mcap, .db3 or a KITTI raw drive)")
    live = left is not None and is_live(left)
    if live and not sbs:
        raise click.UsageError(f"{left} is a live source: give --sbs (one side-by-side "
                               "camera or stream)")
    if latest and not live:
        raise click.UsageError("--latest is for a live source (- or /dev/videoN, with "
                               "--sbs)")
    if sbs or (left is not None and is_video(left)):
        return video_mode(ctx, left, right, sbs, output_dir, suffix, overwrite, summary,
                          preview_video, preview_sbs, range_each_frame, settings, latest)
    if preview_video or preview_sbs or range_each_frame:
        raise click.UsageError("--preview-video, --preview-sbs and --range-each-frame are "
                               "for video input")
    calibration = None
    three_d = dict(depth=depth, cloud=cloud, depth_preview=depth_preview,
                   max_depth=max_depth, units=units)
    many = manifest is not None or output_dir is not None or \
        (left is not None and os.path.isdir(left))
    if many:
        return many_mode(ctx, settings, three_d)
    if left is None or right is None:
        raise click.UsageError("give LEFT and RIGHT images (or folders with --output-dir)")
    if output is None:
        raise click.UsageError("give -o/--output FILE for the disparity map")
    # The library resolves the options first, once, before it reads any file: a
    # calibration file too, which it is given by name.
    by_hand = any(ctx.params[k] is not None for k in ("focal", "baseline", "cx", "cy",
                                                       "doffs", "calib_units"))
    calibration = ctx.params["calib"] if ctx.params["calib"] and not by_hand else \
        opt.calibration(ctx.params)
    rig = None
    if rigs:
        from csw.camera.rig import read_rig
        from csw.io.images import image_header

        with opt.library_errors("LEFT"):
            height, width = image_header(left)[2]
        with opt.library_errors("--rig"):
            rig = read_rig(*rigs, size=(width, height))
    elif rectified_left or ctx.get_parameter_source("frame").name != "DEFAULT" or \
            ctx.get_parameter_source("alpha").name != "DEFAULT":
        raise opt.InputError("--alpha, --frame and --rectified-left need --rig")
    from csw import match_files
    from csw.scale.distributed import cluster

    try:
        with opt.library_errors(), cluster(workers, scheduler) as client:
            result = match_files(left, right, output, confidence=confidence, preview=preview,
                                 cost_map=cost_map, calib=calibration,
                                 memory_limit=memory_limit, client=client, progress=True,
                                 rig=rig, alpha=alpha, rectified_left=rectified_left,
                                 frame=frame, **three_d, **settings)
    except OSError as exc:
        raise opt.write_error(exc) from None
    written = [output, preview, cost_map, confidence, three_d["depth"], three_d["cloud"],
               three_d["depth_preview"], rectified_left]
    click.echo("wrote " + ", ".join(str(path) for path in written if path), err=True)
    click.echo(summary_line(result), err=True)
    for note in getattr(result, "notes", []):
        click.echo(f"csw: {note}", err=True)
