"""``csw match`` on frames: two videos or one side by side, a live source, or a robot log
(a bag, .mcap, .db3 or a KITTI raw drive); a map per frame into --output-dir, a preview
video, messages into a bag."""

from pathlib import Path

import click

from .. import options as opt

NOT_FOR_VIDEO = ("output", "manifest", "cost_map", "depth", "cloud", "depth_preview",
                 "memory_limit", "workers", "scheduler", "rigs", "rectified_left", "calib")


def frame_outputs(params):
    """A video's or a log's outputs beside each frame's map, as a batch's beside each
    pair's (--preview .png: NNNNNN.preview.png; --confidence .pfm)."""
    return {role: str(value) if str(value).startswith(".") else Path(value).suffix
            for role, value in (("preview", params["preview"]),
                                ("confidence", params["confidence"])) if value}


def video_mode(ctx, left, right, sbs, output_dir, suffix, overwrite, summary,
               preview_video, preview_sbs, range_each_frame, settings, latest=False):
    """The video form: two videos or one side-by-side video, a map per frame into
    OUTPUT_DIR and/or a preview video."""
    from csw.scale.stream import match_video as run

    given = [name for name in NOT_FOR_VIDEO
             if ctx.get_parameter_source(name).name != "DEFAULT"]
    if given:
        flag = "--" + given[0].replace("_", "-").rstrip("s")
        raise click.UsageError(f"{flag} is not for video input; give --output-dir for "
                               "a map per frame, or --preview-video")
    if left is None:
        raise click.UsageError("give a video (two, or one with --sbs)")
    if sbs and right is not None:
        raise click.UsageError("--sbs takes one side-by-side video; drop RIGHT")
    if not sbs and right is None:
        raise click.UsageError("give the right camera's video too, or --sbs for one "
                               "side-by-side video")
    if output_dir is None and preview_video is None:
        raise click.UsageError("give --output-dir DIR for a map per frame, "
                               "--preview-video FILE, or both")
    config = stream_config(settings, preview_video, preview_sbs, range_each_frame)
    try:
        with opt.library_errors():
            report = run(left, right, sbs=sbs, out_dir=output_dir, suffix=suffix,
                         overwrite=overwrite, preview_video=preview_video,
                         preview_sbs=preview_sbs, summary=summary,
                         keep_range=not range_each_frame, latest=latest, config=config,
                         frame_outputs=frame_outputs(ctx.params))
    except OSError as exc:
        raise opt.write_error(exc) from None
    report_stream(report, output_dir, summary, range_each_frame)
    if latest:
        click.echo(f"csw: {report['dropped']} frame(s) dropped to keep up (--latest)",
                   err=True)
    counts = report["counts"]
    if counts["failed"] or report["stopped"]:
        raise SystemExit(1)


def stream_config(settings, preview_video, preview_sbs, range_each_frame):
    """The resolved options of a video's or a log's run, checked with its preview and
    range options."""
    from csw.config import params

    if preview_sbs and preview_video is None:
        raise click.UsageError("--preview-sbs needs --preview-video")
    with opt.library_errors():
        config = params.resolve(**settings)
    if range_each_frame and config.range_known:
        raise click.UsageError("--range-each-frame is for a range 'auto'; this run's is "
                               f"{config.dmin}..{config.dmax}")
    return config


def report_stream(report, output_dir, summary, range_each_frame):
    """The lines on stderr after a video's or a log's run."""
    counts = report["counts"]
    latency = report["latency_ms"] or {"median": 0.0, "p99": 0.0}
    where = f"; summary in {summary or Path(output_dir) / 'summary.json'}" \
        if output_dir or summary else ""
    size = "x".join(str(n) for n in report["size"]) if report["size"] else "-"
    low, high = report["range"] or ("-", "-")
    found = ", found on each frame" if range_each_frame else ""
    click.echo(f"{report['frames']} frames ({size}, d {low}..{high}{found}): {counts['ok']} "
               f"matched, {counts['skipped']} skipped, {counts['failed']} failed; "
               f"{report['frames_per_second']:.1f} frames/s, latency median "
               f"{latency['median']:.1f} ms, p99 {latency['p99']:.1f} ms{where}", err=True)
    if report["preview_video"]:
        click.echo(f"wrote {report['preview_video']}", err=True)
    for note in report["stream_notes"]:
        click.echo(f"csw: {note}", err=True)
    for entry in report["failed"][:20]:
        click.echo(f"failed: frame {entry['frame']}: {entry['error']}", err=True)
    for name, note in report["noted"][:3]:
        click.echo(f"csw: frame {name}: {note}", err=True)
    if report["stopped"]:
        click.echo(f"csw: stopped early: {report['stopped']}", err=True)


LOG_ONLY = ("left_topic", "right_topic", "stamp_tolerance", "bag_out", "bag_depth")
# The options a log's run takes beyond the video's (its rig, and the log's own).
LOG_TAKES = ("rigs", "alpha", *LOG_ONLY)


def log_mode(ctx, log_path, right, output_dir, suffix, overwrite, summary, rigs, alpha,
             preview_video, preview_sbs, range_each_frame, settings):
    """The log form: a bag or a KITTI drive, a map per frame into OUTPUT_DIR, a bag of
    messages (--bag-out), a preview video, or any of them."""
    from csw.robot.logs import read_log
    from csw.scale.stream import match_log as run

    given = [name for name in NOT_FOR_VIDEO if name not in LOG_TAKES
             and ctx.get_parameter_source(name).name != "DEFAULT"]
    if given:
        raise click.UsageError(f"--{given[0].replace('_', '-').rstrip('s')} is not for a "
                               "log; give --output-dir for a map per frame, --bag-out, or "
                               "both")
    if right is not None:
        raise click.UsageError("a log holds both cameras; drop RIGHT")
    p = ctx.params
    if output_dir is None and preview_video is None and p["bag_out"] is None:
        raise click.UsageError("give --output-dir DIR for a map per frame, --bag-out OUT "
                               "for messages, --preview-video FILE, or more than one")
    if p["bag_depth"] and p["bag_out"] is None:
        raise click.UsageError("--bag-depth needs --bag-out")
    config = stream_config(settings, preview_video, preview_sbs, range_each_frame)
    rig = None
    if rigs:
        from csw.camera.rig import read_rig

        with opt.library_errors("--rig"):
            rig = read_rig(*rigs)
    try:
        with opt.library_errors():
            log = read_log(log_path, p["left_topic"], p["right_topic"], rig=rig,
                           tolerance=p["stamp_tolerance"], alpha=alpha,
                           colour=p["bag_out"] is not None or preview_sbs)
            try:
                report = run(log, out_dir=output_dir, suffix=suffix, overwrite=overwrite,
                             bag_out=p["bag_out"], depth=p["bag_depth"],
                             preview_video=preview_video, preview_sbs=preview_sbs,
                             summary=summary, keep_range=not range_each_frame,
                             config=config, frame_outputs=frame_outputs(ctx.params))
            finally:
                log.close()
    except OSError as exc:
        raise opt.write_error(exc) from None
    info = report["log"]
    unpaired = info["unpaired"]
    rectified = f"; rectified with the rig of {info['rig']}" if info["rectified_by_csw"] \
        else ""
    click.echo(f"{info['left_topic']} and {info['right_topic']}: {info['pairs']} pairs "
               f"({unpaired['left']} left and {unpaired['right']} right frames unpaired"
               f"{rectified})", err=True)
    report_stream(report, output_dir, summary, range_each_frame)
    if report["bag_written"]:
        click.echo(f"wrote {p['bag_out']}", err=True)
    if report["counts"]["failed"] or report["stopped"]:
        raise SystemExit(1)
