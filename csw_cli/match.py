"""``csw match``: one rectified pair in, one disparity map out."""

import os
import time
from pathlib import Path

import click
import numpy as np

from . import options as opt
from .engine import estimate_tau, run_match, warm_up
from .imageio_utils import (
    OUTPUT_SUFFIXES,
    PNG_MAX_DISPARITY,
    ImageError,
    colorize,
    read_image,
    write_disparity,
    write_float_pfm,
    write_png,
)


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
    if path.is_dir():
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
        try:
            images.append(read_image(path))
        except ImageError as exc:
            raise click.BadParameter(str(exc), param_hint=hint) from None
    return images


def write_outputs(writers):
    """Run (description, writer) pairs; each writes atomically. Runtime errors exit 1."""
    for what, write in writers:
        try:
            write()
        except OSError as exc:
            raise click.ClickException(f"can't write {what}: {exc.strerror or exc}") from None


@click.command(short_help="Compute a disparity map for a rectified pair.")
@click.argument("left", type=click.Path(dir_okay=False))
@click.argument("right", type=click.Path(dir_okay=False))
@click.option("--output", "-o", required=True, type=click.Path(dir_okay=False),
              help="Disparity map: .pfm (float32, inf invalid), .png (uint16 d*256, "
                   "0 invalid, KITTI) or .npy (float32, inf invalid).")
@opt.engine_option
@opt.cost_option()
@opt.window_option
@opt.dmin_option
@opt.dmax_option
@opt.csw_option
@opt.rule_option
@opt.tau_option
@opt.uniqueness_option
@opt.threads_option
@click.option("--preview", type=click.Path(dir_okay=False),
              help="Also write an 8-bit colour PNG of the map (invalid black).")
@click.option("--cost-map", type=click.Path(dir_okay=False),
              help="Also write the minimum-cost map m as PFM (inf where invalid).")
def match(left, right, output, engine, cost, window, dmin, dmax, csw, rule, tau, uniqueness,
          threads, preview, cost_map):
    """Match LEFT against RIGHT (left is the reference) and write the disparity map.

    The match of left pixel x is right pixel x - d, for d in [DMIN, DMAX].  With --csw,
    each row keeps a map of right pixels already claimed by a match whose cost is at most
    TAU, and later searches on the row skip them.

    \b
    Examples:
      csw match left.png right.png -o disp.pfm --dmax 64
      csw match left.png right.png -o disp.png --csw --tau auto --preview view.png
    """
    output = check_output(output, OUTPUT_SUFFIXES, "--output")
    preview = check_output(preview, (".png",), "--preview")
    cost_map = check_output(cost_map, (".pfm",), "--cost-map")
    check_distinct({"LEFT": left, "RIGHT": right},
                   {"--output": output, "--preview": preview, "--cost-map": cost_map})
    if output.suffix.lower() == ".png" and dmax > PNG_MAX_DISPARITY:
        raise click.BadParameter(f"{dmax} is too large for a 16-bit PNG (d*256 must fit); "
                                 "write .pfm or .npy instead", param_hint="--dmax")
    left_img, right_img = load_pair(left, right)
    settings = dict(engine=engine, window=window, dmin=dmin, dmax=dmax, cost=cost,
                    threads=threads)
    compile_s = warm_up(engine=engine, cost=cost)
    tau_note = ""
    tau = opt.tau_value(tau, rule) if csw else -1
    if tau == "auto":
        tau = estimate_tau(left_img, right_img, **settings)
        tau_note = " (auto)"
    start = time.perf_counter()
    result = run_match(left_img, right_img, csw=csw, tau=tau, rule=rule,
                       uniqueness=uniqueness, **settings)
    seconds = time.perf_counter() - start

    disp = result.disparity
    writers = [(str(output), lambda: write_disparity(output, disp))]
    if preview:
        writers.append((str(preview), lambda: write_png(preview, colorize(disp, dmax))))
    if cost_map:
        m = np.where(result.min_cost >= 0, result.min_cost, np.inf).astype(np.float32)
        writers.append((str(cost_map), lambda: write_float_pfm(cost_map, m)))
    write_outputs(writers)

    height, width = disp.shape
    invalid = 100.0 * np.mean(disp < 0)
    tau_text = "none" if tau == float("inf") else f"{tau:g}"
    mode = f"CSW {rule} tau={tau_text}{tau_note}" if csw else "plain"
    click.echo(
        f"{width}x{height} d {dmin}..{dmax} {cost.upper()} {window}x{window} {mode} "
        f"({engine} engine): "
        f"{seconds:.3f} s (compile {compile_s:.2f} s), evaluated "
        f"{100.0 * result.evaluated / max(result.candidates, 1):.1f}% of candidates, "
        f"invalid {invalid:.1f}%", err=True)
