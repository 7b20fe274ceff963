"""The files and folders of ``csw rectify``: a raw pair of image files rectified into a
folder with its calibration (``rectify_files``), and many pairs with one
:class:`csw.camera.rectify.Rectifier` (``rectify_many``), each written whole or not at
all."""

import contextlib
import os

from .rectify import Rectifier


def _folder(path):
    """``path`` as a folder, created with its parents if missing; OptionError naming it
    when it is something else or can't be made."""
    from pathlib import Path

    from ..config.params import OptionError

    path = Path(path)
    if path.exists() and not path.is_dir():
        raise OptionError("output_dir", f"{path} exists and is not a folder")
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OptionError("output_dir", f"can't create the folder {path} "
                                        f"({exc.strerror or exc})") from None
    return path


def _rig_files(rig):
    """The files a rig was read from, as named inputs (csw.io.safety.check_outputs)."""
    return {f"rig {i + 1}": path for i, path in enumerate(getattr(rig, "paths", ()))}


def check_images(rig, *paths):
    """Each image file's size, as its header gives it, against the rig's, before any
    map is built: OptionError naming the image ("left", "right") that can't be read,
    or the rig when the sizes differ."""
    from ..config.params import OptionError
    from ..io.images import ImageError
    from ..io.sources import open_source

    for path, name in zip(paths, ("left", "right"), strict=False):
        try:
            height, width = open_source(path, name, probe=False).shape[:2]
        except ImageError as exc:
            exc.option = name
            raise
        try:
            rig.check_size((width, height), f"the {name} image")
        except ValueError as exc:
            raise OptionError("rig", str(exc)) from None


def rectify_files(left, right, rig, out_dir, alpha=0.0, threads=None):
    """Rectify a raw pair of image files with ``rig`` (a Rig) into ``out_dir``:
    left.png, right.png (the images' own type, gray or colour) and calib.txt (the
    rectified pair's calibration, Middlebury style, so that ``csw match
    out_dir/left.png out_dir/right.png --depth z.pfm`` uses it), all or none written.
    Returns the Rectifier."""

    from ..io.atomic import atomic_write_all
    from ..io.formats import png_writer
    from ..io.images import ImageError, read_colour
    from ..io.safety import check_outputs

    made = _missing_folders(out_dir)
    out_dir = _folder(out_dir)
    outputs = {"left": out_dir / "left.png", "right": out_dir / "right.png",
               "calib": out_dir / "calib.txt"}
    try:
        check_outputs({"left_raw": left, "right_raw": right, **_rig_files(rig)}, outputs,
                      {"left": (".png",), "right": (".png",), "calib": (".txt",)})
        check_images(rig, left, right)
        rect = Rectifier(rig, alpha, threads)
        images = []
        for path, name in ((left, "left"), (right, "right")):
            try:
                images.append(read_colour(path))
            except ImageError as exc:
                exc.option = name
                raise
        left_r, right_r = rect.rectify(*images)
        text = rect.calib_text().encode()

        def write_text(tmp):
            with open(tmp, "wb") as f:
                f.write(text)

        atomic_write_all([(outputs["left"], png_writer(left_r)),
                          (outputs["right"], png_writer(right_r)),
                          (outputs["calib"], write_text)])
    except BaseException:
        for folder in made:  # the folders this run made, still empty: none asked for
            with contextlib.suppress(OSError):
                folder.rmdir()
        raise
    return rect


def _missing_folders(path):
    """The folders of ``path`` and its parents that do not exist yet, deepest first."""
    from pathlib import Path

    path = Path(path).absolute()
    return [p for p in (path, *path.parents) if not os.path.lexists(p)]


def rectify_many(jobs, rig, out_dir, alpha=0.0, threads=None, progress=False):
    """Rectify every pair of ``jobs`` (csw.Job, from csw.jobs_from_folders or
    csw.jobs_from_manifest) with one Rectifier, its maps built once, into
    ``out_dir/left/NAME.png`` and ``out_dir/right/NAME.png``, with the rectified
    calibration in ``out_dir/left/calib.txt`` (where ``csw match out_dir/left
    out_dir/right -O maps`` finds it beside each left image).  Each pair is written whole
    or not at all; a pair that fails is reported and the others go on.  Returns
    {"ok": count, "failed": [(name, one-line error), ...], "rectifier": the Rectifier}.
    progress: a progress bar on stderr."""
    from pathlib import Path

    from ..io.atomic import atomic_write_all
    from ..io.formats import png_writer
    from ..io.images import read_colour
    from ..io.safety import check_outputs

    rect = Rectifier(rig, alpha, threads)
    out_dir = _folder(out_dir)
    folders = {side: _folder(out_dir / side) for side in ("left", "right")}
    calib = folders["left"] / "calib.txt"
    text = rect.calib_text().encode()
    check_outputs(_rig_files(rig), {"calib": calib}, {"calib": (".txt",)})
    atomic_write_all([(calib, lambda tmp: Path(tmp).write_bytes(text))])
    from ..io.progress import progress_bar

    done, failed = 0, []
    bar = progress_bar(len(jobs), "csw rectify", "pair", progress)
    for job in jobs:
        try:
            if job.problem:
                raise ValueError(job.problem)
            outputs = {side: folders[side] / f"{job.name}.png" for side in folders}
            check_outputs({"left_raw": job.left, "right_raw": job.right,
                           **_rig_files(rig)}, outputs,
                          {"left": (".png",), "right": (".png",)})
            pair = rect.rectify(read_colour(job.left), read_colour(job.right))
            atomic_write_all([(outputs[side], png_writer(image))
                              for side, image in zip(folders, pair, strict=True)])
            done += 1
        except (ValueError, OSError) as exc:
            failed.append((job.name, str(exc).splitlines()[0] if str(exc) else
                           type(exc).__name__))
        bar.update(1)
    bar.close()
    return {"ok": done, "failed": failed, "rectifier": rect}
