"""``csw match``: one rectified pair in, one disparity map out; or many pairs into a folder."""

import os
from pathlib import Path

import click
import numpy as np

from csw.batch import jobs_from_folders, jobs_from_manifest, match_many
from csw.io import (
    OUTPUT_SUFFIXES,
    PNG_MAX_DISPARITY,
    atomic_write_all,
    colorize,
    disparity_writer,
    pfm_writer,
    png_writer,
    read_image,
)
from csw.matching import check_tau_use
from csw.matching import match as match_pair
from csw.tau import tau_label
from csw.tiled import TILED_SUFFIXES, match_tiled, parse_size, too_big_for_whole

from . import options as opt


def check_output(path, suffixes, param_hint):
    """Fail before any work if ``path`` has the wrong suffix or can't be written."""
    if path is None:
        return None
    path = Path(path)
    if path.suffix.lower() not in suffixes:
        raise click.BadParameter(
            f"unknown extension {path.suffix or '(none)'!r}; use {', '.join(suffixes)}",
            param_hint=param_hint)
    folder = path.parent if str(path.parent) else Path(".")
    if not folder.is_dir():
        raise click.BadParameter(f"folder {str(folder)!r} does not exist; create it first",
                                 param_hint=param_hint)
    if not os.access(folder, os.W_OK):
        raise click.BadParameter(f"folder {str(folder)!r} is not writable",
                                 param_hint=param_hint)
    if path.is_dir() and not (path.suffix.lower() == ".zarr" and (path / "zarr.json").exists()):
        raise click.BadParameter(f"{str(path)!r} is a directory", param_hint=param_hint)
    return path


def check_distinct(inputs, outputs):
    """Refuse an output that would overwrite an input or another output (an input may
    well be given twice)."""
    seen = {os.path.realpath(path): hint for hint, path in inputs.items()}
    for hint, path in outputs.items():
        if path is None:
            continue
        key = os.path.realpath(path)
        if key in seen:
            raise click.BadParameter(f"{path} is also given as {seen[key]}; an output must not "
                                     "overwrite an input or another output", param_hint=hint)
        seen[key] = hint


def load_pair(left_path, right_path):
    """Read both images as gray, or fail with a usage error naming the bad one."""
    images = []
    for hint, path in (("LEFT", left_path), ("RIGHT", right_path)):
        with opt.library_errors(hint):
            images.append(read_image(path))
    return images


def write_outputs(items):
    """Write every (path, write_to) together: all of them or none. Write errors exit 1."""
    try:
        atomic_write_all(items)
    except OSError as exc:
        raise write_error(exc) from None


def write_error(exc):
    """The one-line error (exit 1) for an OSError while writing."""
    where = f" {exc.filename}" if getattr(exc, "filename", None) else ""
    return click.ClickException(f"can't write{where}: {exc.strerror or exc}")


def summary_line(result, shape, stripes=None):
    """The one line ``csw match`` prints on stderr about a match."""
    s = result.settings
    height, width = shape
    tau_note = " (auto)" if s["tau_source"] == "auto" else ""
    mode = (f"CSW {s['csw_rule']} tau={tau_label(s['tau'])}{tau_note}" if s["csw"]
            else "plain")
    return (f"{width}x{height} d {s['dmin']}..{s['dmax']} {s['cost'].upper()} "
            f"{s['window']}x{s['window']} {mode}, preset {s['preset']} "
            f"({s['engine']} engine{f', {stripes} stripe(s)' if stripes else ''}): "
            f"{result.seconds:.3f} s (compile {result.compile_seconds:.2f} s), evaluated "
            f"{100.0 * result.evaluated / max(result.candidates, 1):.1f}% of candidates, "
            f"invalid {100.0 * result.invalid_share:.1f}%")


def cluster_client(workers, scheduler):
    """A Dask client for --workers / --scheduler, or None to run here."""
    if workers is None and scheduler is None:
        return None
    if workers is not None and scheduler is not None:
        raise click.UsageError("give --workers N (a cluster on this machine) or --scheduler "
                               "ADDRESS (an existing one), not both")
    from csw import distributed

    try:
        if scheduler is not None:
            return distributed.remote_client(scheduler)
        return distributed.local_client(workers)
    except ImportError as exc:
        raise click.UsageError(str(exc)) from None
    except ValueError as exc:
        raise click.BadParameter(str(exc), param_hint="--scheduler" if scheduler
                                 else "--workers") from None


def match_batch(left, right, manifest, output_dir, suffix, overwrite, summary, settings,
                workers=None, scheduler=None):
    """The batch form: pairs from two folders or a manifest, into OUTPUT_DIR."""
    if output_dir is None:
        raise click.UsageError("matching many pairs needs --output-dir DIR")
    out = Path(output_dir)
    if not out.is_dir():
        raise click.BadParameter(f"folder {output_dir!r} does not exist; create it first",
                                 param_hint="--output-dir")
    with opt.library_errors("--manifest" if manifest else "LEFT"):
        jobs = jobs_from_manifest(manifest) if manifest else jobs_from_folders(left, right)
    client = cluster_client(workers, scheduler)
    try:
        with opt.library_errors():
            report = match_many(jobs, out, suffix=suffix, overwrite=overwrite, progress=True,
                                summary=summary, client=client, **settings)
    finally:
        if client is not None:
            from csw.distributed import close

            close(client)
    counts = report["counts"]
    summary_path = summary or out / "summary.json"
    click.echo(f"{counts['ok']} matched, {counts['skipped']} skipped (output exists; "
               f"--overwrite redoes them), {counts['failed']} failed; summary in "
               f"{summary_path}", err=True)
    for entry in report["pairs"]:
        if entry["status"] == "failed":
            click.echo(f"failed: {entry['name']}: {entry['error']}", err=True)
    if counts["failed"]:
        raise SystemExit(1)


STRIPED_INPUTS = (".npy", ".zarr")  # read by rows only (csw.sources)


def use_stripes(left, right, output, confidence, memory_limit, cluster, settings):
    """Whether one pair goes through csw.match_tiled: asked for (a memory limit, a
    cluster), needed by a format only it reads or writes, or a pair whose whole-image
    match would not fit the default memory limit.  Both give the same map."""
    if memory_limit is not None or cluster:
        return True
    if output.suffix.lower() not in OUTPUT_SUFFIXES or \
            (confidence is not None and confidence.suffix.lower() != ".pfm") or \
            any(Path(p).suffix.lower() in STRIPED_INPUTS for p in (left, right)):
        return True
    with opt.library_errors("LEFT"):
        return too_big_for_whole(left, **settings)


def match_striped(left, right, output, confidence, preview, memory_limit, workers,
                  scheduler, settings):
    """One pair, stripe by stripe (here, or as tasks on a Dask cluster)."""
    client = cluster_client(workers, scheduler)
    try:
        with opt.library_errors():
            result = match_tiled(left, right, output, confidence=confidence, preview=preview,
                                 memory_limit=memory_limit, client=client, progress=True,
                                 **settings)
    except OSError as exc:
        raise write_error(exc) from None
    finally:
        if client is not None:
            from csw.distributed import close

            close(client)
    click.echo(summary_line(result, result.shape, len(result.plan.stripes)), err=True)


def memory_size(ctx, param, value):
    if value is None:
        return None
    try:
        size = parse_size(value)
    except ValueError as exc:
        raise click.BadParameter(str(exc)) from None
    if size <= 0:
        raise click.BadParameter("must be more than 0")
    return size


@click.command(short_help="Compute disparity maps for rectified pairs.")
@click.argument("left", type=click.Path(), required=False)
@click.argument("right", type=click.Path(), required=False)
@click.option("--output", "-o", type=click.Path(),
              help="Disparity map: .pfm (float32, inf invalid), .png (uint16 d*256, "
                   "0 invalid, KITTI), .npy (float32, inf invalid), .tif/.tiff (tiled "
                   "float32, NaN invalid) or .zarr.")
@click.option("--manifest", type=click.Path(dir_okay=False, exists=True),
              help="Many pairs: a CSV file of left,right[,name] lines (paths relative to "
                   "it). Needs --output-dir.")
@click.option("--output-dir", "-O", type=click.Path(file_okay=False),
              help="Many pairs: the folder for their maps (NAME.pfm ...) and summary.json. "
                   "LEFT and RIGHT may then be folders, paired by file name.")
@click.option("--suffix", type=click.Choice(OUTPUT_SUFFIXES), default=".pfm",
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
@opt.engine_option(default=None)
@opt.cost_option(default=None)
@opt.window_option(default=None)
@opt.dmin_option
@opt.dmax_option
@opt.csw_option
@opt.rule_option()
@opt.tau_option
@opt.uniqueness_option
@opt.threads_option
@click.option("--preview", type=click.Path(dir_okay=False),
              help="Also write an 8-bit colour PNG of the map (invalid black).")
@click.option("--cost-map", type=click.Path(dir_okay=False),
              help="Also write the minimum-cost map m as PFM (inf where invalid).")
@click.option("--confidence", "confidence_map", type=click.Path(dir_okay=False),
              help="Also write the confidence (0..1: how much the best cost beats the "
                   "second best) as PFM.")
@opt.stage_options
@click.pass_context
def match(ctx, left, right, output, manifest, output_dir, suffix, overwrite, summary, workers,
          scheduler, memory_limit, engine, cost, window, dmin, dmax, csw, rule, tau, uniqueness,
          threads, preview, cost_map, confidence_map, **stage_values):
    """Match LEFT against RIGHT (left is the reference) and write the disparity map.

    The match of left pixel x is right pixel x - d, for d in [DMIN, DMAX].  With --csw,
    each row keeps a map of right pixels already claimed by a match whose cost is at most
    TAU, and later searches on the row skip them.

    The default preset, accurate, matches census codes and leaves invalid the pixels the
    left-right check or the speckle filter refuses (add --fill background for a dense
    map); --preset raw gives the contract's dense winner-take-all map.

    Many pairs: give two folders (pairs by file name) or --manifest, and --output-dir.
    A pair that fails is reported and the others go on; the exit code is 1 if any failed.

    \b
    Examples:
      csw match left.png right.png -o disp.pfm --dmax 64
      csw match left.png right.png -o disp.pfm --subpixel linear --fill background
      csw match left.png right.png -o disp.png --preset raw --csw --tau auto
      csw match lefts/ rights/ --output-dir maps/ --dmax 128
      csw match --manifest pairs.csv -O maps/ --suffix .png
      csw match lefts/ rights/ -O maps/ --workers 2
      csw match big_left.tif big_right.tif -o disp.tif --memory-limit 1GiB
    """
    settings = dict(dmin=dmin, dmax=dmax, csw=csw, tau=tau, uniqueness=uniqueness,
                    threads=threads)
    with opt.library_errors("--tau"):
        check_tau_use(csw, tau)  # before any image is read
    # Engine, cost, window and the stages come from the preset unless given.
    settings.update(opt.given(ctx, ["engine", "cost", "window", "rule", *opt.STAGE_NAMES],
                              rename={"rule": "csw_rule"}))
    many = manifest is not None or output_dir is not None or \
        (left is not None and Path(left).is_dir())
    if many:
        if output or preview or cost_map or confidence_map or memory_limit:
            raise click.UsageError("-o, --preview, --cost-map, --confidence and "
                                   "--memory-limit are for one pair; many pairs write into "
                                   "--output-dir")
        if bool(manifest) == (left is not None):
            raise click.UsageError("give either LEFT_DIR RIGHT_DIR or --manifest, not both")
        if left is not None and (right is None or not Path(right).is_dir()):
            raise click.UsageError("with a LEFT folder, RIGHT must be a folder too")
        if suffix == ".png" and dmax > PNG_MAX_DISPARITY:
            raise click.BadParameter(f"{dmax} is too large for a 16-bit PNG (d*256 must fit); "
                                     "use --suffix .pfm or .npy", param_hint="--dmax")
        return match_batch(left, right, manifest, output_dir, suffix, overwrite, summary,
                           settings, workers, scheduler)
    if left is None or right is None:
        raise click.UsageError("give LEFT and RIGHT images (or folders with --output-dir)")
    if output is None:
        raise click.UsageError("give -o/--output FILE for the disparity map")
    output = check_output(output, TILED_SUFFIXES, "--output")
    preview = check_output(preview, (".png",), "--preview")
    cost_map = check_output(cost_map, (".pfm",), "--cost-map")
    confidence_map = check_output(confidence_map, (".pfm", ".npy", ".tif", ".tiff", ".zarr"),
                                  "--confidence")
    check_distinct({"LEFT": left, "RIGHT": right},
                   {"--output": output, "--preview": preview, "--cost-map": cost_map,
                    "--confidence": confidence_map})
    if output.suffix.lower() == ".png" and dmax > PNG_MAX_DISPARITY:
        raise click.BadParameter(f"{dmax} is too large for a 16-bit PNG (d*256 must fit); "
                                 "write .pfm or .npy instead", param_hint="--dmax")
    if use_stripes(left, right, output, confidence_map, memory_limit, workers or scheduler,
                   settings):
        if cost_map:
            raise click.UsageError("--cost-map is not written for pairs matched in stripes "
                                   "(a large pair, --memory-limit, --workers, .tif/.zarr)")
        return match_striped(left, right, output, confidence_map, preview, memory_limit,
                             workers, scheduler, settings)
    left_img, right_img = load_pair(left, right)
    with opt.library_errors():
        result = match_pair(left_img, right_img, want_confidence=bool(confidence_map),
                            **settings)

    disp = result.disparity
    writers = [(output, disparity_writer(output, disp))]
    if preview:
        writers.append((preview, png_writer(colorize(disp, dmax))))
    if cost_map:
        m = np.where(result.min_cost >= 0, result.min_cost, np.inf).astype(np.float32)
        writers.append((cost_map, pfm_writer(m)))
    if confidence_map:
        writers.append((confidence_map, pfm_writer(result.confidence)))
    write_outputs(writers)
    click.echo(summary_line(result, disp.shape), err=True)
