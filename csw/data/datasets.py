"""The dataset registry: Middlebury pairs with ground truth, and the synthetic scene.

Where files come from, in this order:
  1. the data directory: ``--data-dir`` or the environment variable CSW_DATA_DIR;
  2. the user cache (``pooch.os_cache("csw")``, or CSW_CACHE_DIR);
  3. a download from the official Middlebury URL into the cache, checked against the
     sha256 below.  ``CSW_DATA_MIRROR`` replaces the official host prefix (for mirrors
     and for tests).

Both directories use the same layout as the registry's relative paths, e.g.
``tsukuba/scene1.row3.col3.ppm`` and ``wood1/thirdsize/view1.png``.
Files, sources and scale conventions: ``../shared/datasets/SOURCES.md`` in development.
Benchmark folders in their own published layouts (Middlebury 2014/2021, KITTI) are read
by :mod:`csw.layouts`.
"""

import hashlib
import os
import shutil
import tempfile
import zipfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

OFFICIAL_PREFIX = "https://vision.middlebury.edu/stereo/"

# relative path: (official URL, sha256 of the file, member name if the URL is a zip)
FILES = {
    "tsukuba/all.png": ("https://vision.middlebury.edu/stereo/eval/newEval/tsukuba/all.png", "17630759fd7f99aba9b8d17ec66973974b30a938c9c542ce8ec4f497e3ea64ca", None),
    "tsukuba/disc.png": ("https://vision.middlebury.edu/stereo/eval/newEval/tsukuba/disc.png", "5cc99c325e09f24f5f812ccd8022ea25014a2f85a84731c899199e26d3c16cfc", None),
    "tsukuba/groundtruth.png": ("https://vision.middlebury.edu/stereo/eval/newEval/tsukuba/groundtruth.png", "d59622b3a43249bbc93beec2e326df6428580a63d13cbf64da4a5659dfee270b", None),
    "tsukuba/imL.png": ("https://vision.middlebury.edu/stereo/eval/newEval/tsukuba/imL.png", "e29144841f4e2200e88eb6ad928cfa3ee0c55ccac0a28532c9293c4a5e0b284d", None),
    "tsukuba/imR.png": ("https://vision.middlebury.edu/stereo/eval/newEval/tsukuba/imR.png", "fb4e8b1561c177a9aba23693bd576d0e06f5778b8d44e1c1cc5c5dd35d5fd1d4", None),
    "tsukuba/nonocc.png": ("https://vision.middlebury.edu/stereo/eval/newEval/tsukuba/nonocc.png", "826a3b8521c9fdcb8f05401e4676262c68d85251adbae1507e2c984c19d5b211", None),
    "tsukuba/scene1.row3.col3.ppm": ("https://vision.middlebury.edu/stereo/data/scenes2001/data/tsukuba/scene1.row3.col3.ppm", "1d326401c70e4bce95f0415a612dd00fa2984db89754f28d490b816aa731361a", None),
    "tsukuba/scene1.row3.col4.ppm": ("https://vision.middlebury.edu/stereo/data/scenes2001/data/tsukuba/scene1.row3.col4.ppm", "c8048c2e0d834488adfae1c2525f4c004907b369dc90730ca11bf1f6dd8d925d", None),
    "tsukuba/truedisp.row3.col3.pgm": ("https://vision.middlebury.edu/stereo/data/scenes2001/data/tsukuba/truedisp.row3.col3.pgm", "3192e1b8a1ad50fa6ac743cbe93aea54066bc93d2ebee432a04e7cd759450296", None),
    "venus/all.png": ("https://vision.middlebury.edu/stereo/eval/newEval/venus/all.png", "47415362ed6c2ca7bd61d52f7cc68e858098b581b591dc0cb0fc019e331a70ba", None),
    "venus/disc.png": ("https://vision.middlebury.edu/stereo/eval/newEval/venus/disc.png", "b449e1cdc7ed573f1c98e4359102b97a51761da8d3bc675cad45b3969005990d", None),
    "venus/disp2.pgm": ("https://vision.middlebury.edu/stereo/data/scenes2001/data/venus/disp2.pgm", "7d7b78ba89b1a8b8973cfebd61f2ef35b5adec70b2fb50817c2bd66e06a10170", None),
    "venus/groundtruth.png": ("https://vision.middlebury.edu/stereo/eval/newEval/venus/groundtruth.png", "706cb85034e3595a45d0b9d6e4af657ebcc489ee0e6c2892dfcf0b5dc7906a7e", None),
    "venus/im2.ppm": ("https://vision.middlebury.edu/stereo/data/scenes2001/data/venus/im2.ppm", "fef870c1e2471fe5b3b2bac9ca71810e8503e1489e4203288a982b40355b9172", None),
    "venus/im6.ppm": ("https://vision.middlebury.edu/stereo/data/scenes2001/data/venus/im6.ppm", "b2fca7b6f3aa7e1a34bc5eac2d99cbbc5dfc77ce531777b71153e2ed73290004", None),
    "venus/imL.png": ("https://vision.middlebury.edu/stereo/eval/newEval/venus/imL.png", "f5b442838ca32a3f31ceab7322898afce4c6ecb185529a5589a440024e12b636", None),
    "venus/imR.png": ("https://vision.middlebury.edu/stereo/eval/newEval/venus/imR.png", "f5b4b94e1b59b68120061ca65aa23ada1529cc93d17b9a4f5d048cc511256cc7", None),
    "venus/nonocc.png": ("https://vision.middlebury.edu/stereo/eval/newEval/venus/nonocc.png", "fb2db205bb6a83e00fd360a1b7580886d2c65b6c2f4a0f43b36dc710d2eb2db6", None),
    "sawtooth/disp2.pgm": ("https://vision.middlebury.edu/stereo/data/scenes2001/data/sawtooth/disp2.pgm", "1659b31fbdb75332499f6307bad0f7166014f197f41dab1caaeabc2cb9678129", None),
    "sawtooth/im2.ppm": ("https://vision.middlebury.edu/stereo/data/scenes2001/data/sawtooth/im2.ppm", "a6698d41e161df197910ead7debb4e0ff07899ab785e34805275e329994e74f8", None),
    "sawtooth/im6.ppm": ("https://vision.middlebury.edu/stereo/data/scenes2001/data/sawtooth/im6.ppm", "ab427b244b141b072470a67f3d5630cb8127337eb1f5b3625d5102deb7ae4950", None),
    "cones/all.png": ("https://vision.middlebury.edu/stereo/eval/newEval/cones/all.png", "d9a367fe82b2da6d1c91a8287804bace86b878bcac8bafcc43d011d11268be37", None),
    "cones/disc.png": ("https://vision.middlebury.edu/stereo/eval/newEval/cones/disc.png", "b512f4ee425202a501dea3ca4aa666a33c541484d334659e705de9132bcc8008", None),
    "cones/disp2.png": ("https://vision.middlebury.edu/stereo/data/scenes2003/newdata/cones/disp2.png", "d082b192d7893ef597dfaa9af5c7fea9cb0196808be42d40b80fbf47bb96f561", None),
    "cones/disp6.png": ("https://vision.middlebury.edu/stereo/data/scenes2003/newdata/cones/disp6.png", "0300ae8e912e700337b3cbcc5c767d381844a0a50f40aa23e4340b19d28452fe", None),
    "cones/im2.png": ("https://vision.middlebury.edu/stereo/data/scenes2003/newdata/cones/im2.png", "e9875cec273b9c7a36ab8a0556b5c8451dd90cf50b5c8f30f4ab3bc8f201da92", None),
    "cones/im6.png": ("https://vision.middlebury.edu/stereo/data/scenes2003/newdata/cones/im6.png", "a3795d564445b1e041a88fec490d4140efec87c9a4c64c1b56f7240c3a4fc727", None),
    "cones/nonocc.png": ("https://vision.middlebury.edu/stereo/eval/newEval/cones/nonocc.png", "0fd35104fcc1acb21840a5a87187d571584fff3bf0b01bb5a087bc4a1e324d0f", None),
    "teddy/all.png": ("https://vision.middlebury.edu/stereo/eval/newEval/teddy/all.png", "8c9cd34e66966d08bd7913d740de89ff3274b509eb827eb94583443c10f884d6", None),
    "teddy/disc.png": ("https://vision.middlebury.edu/stereo/eval/newEval/teddy/disc.png", "f5df7617f730529b0c8500c87f197da02e9c501b0ea462efa330bc1d83098be8", None),
    "teddy/disp2.png": ("https://vision.middlebury.edu/stereo/data/scenes2003/newdata/teddy/disp2.png", "695e92dd08819e82e22a0001cd5a34e67859246475db5df38a0ab55e66d1f412", None),
    "teddy/disp6.png": ("https://vision.middlebury.edu/stereo/data/scenes2003/newdata/teddy/disp6.png", "53da1af1e01089d806109713aed342179b4deae2caa8157e1a119f22f306395e", None),
    "teddy/im2.png": ("https://vision.middlebury.edu/stereo/data/scenes2003/newdata/teddy/im2.png", "092142723fd63f1f4867daaf66d85e8228a4fe2c704becd0091b7b599e618f00", None),
    "teddy/im6.png": ("https://vision.middlebury.edu/stereo/data/scenes2003/newdata/teddy/im6.png", "b13366171eaa15cbb30c1cfb6bb0d18bec7a3977c92c49a641245dc40f75ec9b", None),
    "teddy/nonocc.png": ("https://vision.middlebury.edu/stereo/eval/newEval/teddy/nonocc.png", "f51cd8acc9ad7b584ffa7e129c02c1aafbc46ddf56afadb0b3ff6fe4dfe331f4", None),
    "wood1/thirdsize/disp1.png": ("https://vision.middlebury.edu/stereo/data/scenes2006/ThirdSize/zip-2views/Wood1-2views.zip", "59538ff90cb7195a7719eaa00aac71d435f16afb824deaaf80dfdc1dcc905c83", "Wood1/disp1.png"),
    "wood1/thirdsize/disp5.png": ("https://vision.middlebury.edu/stereo/data/scenes2006/ThirdSize/zip-2views/Wood1-2views.zip", "665cda36e777853497d840c6442c18dc2ed56c0e7cf1f225045494c449a5658b", "Wood1/disp5.png"),
    "wood1/thirdsize/view1.png": ("https://vision.middlebury.edu/stereo/data/scenes2006/ThirdSize/zip-2views/Wood1-2views.zip", "eaba474341873fd65f56ea5c0c39d2f55cb22d86d3ea08ef6ef156e056edc04e", "Wood1/view1.png"),
    "wood1/thirdsize/view5.png": ("https://vision.middlebury.edu/stereo/data/scenes2006/ThirdSize/zip-2views/Wood1-2views.zip", "65ff99c9cb3153bd9036a2f5213760586d84ff8ab96efef3120ff0a9b3ca2f67", "Wood1/view5.png"),
    "baby1/halfsize/disp1.png": ("https://vision.middlebury.edu/stereo/data/scenes2006/HalfSize/zip-2views/Baby1-2views.zip", "f33b4f33755fa33220c57ff12344db98a0e90cd36094fb63d58741da95733860", "Baby1/disp1.png"),
    "baby1/halfsize/disp5.png": ("https://vision.middlebury.edu/stereo/data/scenes2006/HalfSize/zip-2views/Baby1-2views.zip", "bee428a77b6f6d03ea22f0fef94a0317d13d2906e57a7ef8dbb757ce550b8ddf", "Baby1/disp5.png"),
    "baby1/halfsize/view1.png": ("https://vision.middlebury.edu/stereo/data/scenes2006/HalfSize/zip-2views/Baby1-2views.zip", "ca521888e2e863a98942a7b6cac4c2b9050b33e7939597a24bf38300cd2174cb", "Baby1/view1.png"),
    "baby1/halfsize/view5.png": ("https://vision.middlebury.edu/stereo/data/scenes2006/HalfSize/zip-2views/Baby1-2views.zip", "65a4a16aa6aac620fd81eba32dc3f45d6e1848887ea29d7ad63ca38f3c8e9814", "Baby1/view5.png"),
    "baby1/thirdsize/disp1.png": ("https://vision.middlebury.edu/stereo/data/scenes2006/ThirdSize/zip-2views/Baby1-2views.zip", "d6d586d760d571c0d0f9996ca372ad202e721233c9229cd0a6461c34d9a50acb", "Baby1/disp1.png"),
    "baby1/thirdsize/disp5.png": ("https://vision.middlebury.edu/stereo/data/scenes2006/ThirdSize/zip-2views/Baby1-2views.zip", "1ca510e4da95703fa5903412deace0df92379079caab6180b07a004288c378af", "Baby1/disp5.png"),
    "baby1/thirdsize/view1.png": ("https://vision.middlebury.edu/stereo/data/scenes2006/ThirdSize/zip-2views/Baby1-2views.zip", "7b76b595c372042770d12378823a0a2776bc3bd473f46583344884c7d9b022e5", "Baby1/view1.png"),
    "baby1/thirdsize/view5.png": ("https://vision.middlebury.edu/stereo/data/scenes2006/ThirdSize/zip-2views/Baby1-2views.zip", "2bf36002c7d7b246a25842689287b61ea7daad32be264164311abb5d0d1f100a", "Baby1/view5.png"),
    "bowling1/halfsize/disp1.png": ("https://vision.middlebury.edu/stereo/data/scenes2006/HalfSize/zip-2views/Bowling1-2views.zip", "72cfa781a389abafe8c52f84d3465da1bbe53ab33d78a7a3a55b6a0d877430fa", "Bowling1/disp1.png"),
    "bowling1/halfsize/disp5.png": ("https://vision.middlebury.edu/stereo/data/scenes2006/HalfSize/zip-2views/Bowling1-2views.zip", "a935d71f20e46b1d63323b9bcb400be55e007d39d106d3f969d4a0e8b5541458", "Bowling1/disp5.png"),
    "bowling1/halfsize/view1.png": ("https://vision.middlebury.edu/stereo/data/scenes2006/HalfSize/zip-2views/Bowling1-2views.zip", "e2a8036e76bd1bcafd5468fa74c4cd40f478b0c965d47a121f6a214fa067479e", "Bowling1/view1.png"),
    "bowling1/halfsize/view5.png": ("https://vision.middlebury.edu/stereo/data/scenes2006/HalfSize/zip-2views/Bowling1-2views.zip", "a6582d35aac33cf2bdfaa089262c6fd9ec846ada081d83208992e45b35c2c4c1", "Bowling1/view5.png"),
    "bowling1/thirdsize/disp1.png": ("https://vision.middlebury.edu/stereo/data/scenes2006/ThirdSize/zip-2views/Bowling1-2views.zip", "ff74e426be19c296281ec056c83ee49eba5256ba5d3ba8d9b274f2dd80054ae9", "Bowling1/disp1.png"),
    "bowling1/thirdsize/disp5.png": ("https://vision.middlebury.edu/stereo/data/scenes2006/ThirdSize/zip-2views/Bowling1-2views.zip", "ccb17f1c8e746d7d0c7d758e5fa7dd76cb63c5d0e98c93406cfc50e12955658d", "Bowling1/disp5.png"),
    "bowling1/thirdsize/view1.png": ("https://vision.middlebury.edu/stereo/data/scenes2006/ThirdSize/zip-2views/Bowling1-2views.zip", "4192be9f0c299cd4102fda19e240580c5a44469fce94b04b96c53bd7cf251cd2", "Bowling1/view1.png"),
    "bowling1/thirdsize/view5.png": ("https://vision.middlebury.edu/stereo/data/scenes2006/ThirdSize/zip-2views/Bowling1-2views.zip", "dc782f5a5b9e0228d14a4709c2795cd36ef849b491c350c358cd2503e062808b", "Bowling1/view5.png"),
}


@dataclass(frozen=True)
class Dataset:
    """One stereo pair in the registry.

    gt_scale: stored value / gt_scale = disparity in pixels of the loaded images; a stored
        0 means unknown.  border: pixels on every side excluded from scoring.
    masks: region name -> file; Middlebury v2 masks (255 = in the region; disc: 255 near a
        discontinuity, 128 elsewhere evaluated, 0 not evaluated).
    size_factor: the image size relative to the full-size original (1/3 = third size).
    """

    name: str
    left: str
    right: str
    gt: str
    gt_scale: float
    dmax: int
    description: str
    size: str  # WIDTHxHEIGHT of the images
    border: int = 0
    masks: dict = field(default_factory=dict)
    size_factor: float = 1.0
    paper: str | None = None  # the paper's name for the scene, where TABLE II has it

    @property
    def files(self):
        return [self.left, self.right, self.gt, *self.masks.values()]


def _v2(scene, left, right, gt, scale, dmax, size, border=0, masks=True, paper=None, desc=""):
    m = {r: f"{scene}/{r}.png" for r in ("nonocc", "all", "disc")} if masks else {}
    return Dataset(scene, f"{scene}/{left}", f"{scene}/{right}", f"{scene}/{gt}", scale,
                   dmax, desc, size, border, m, 1.0, paper)


def _2006(scene, size, dmax, paper, pixels):
    folder = {"third": "thirdsize", "half": "halfsize"}[size]
    factor = {"third": 1 / 3, "half": 1 / 2}[size]
    name = scene if size == "third" else f"{scene}-half"
    base = f"{scene}/{folder}"
    return Dataset(name, f"{base}/view1.png", f"{base}/view5.png", f"{base}/disp1.png",
                   round(1 / factor), dmax,
                   f"Middlebury 2006 {scene.capitalize()}, {size} size", pixels, 0, {}, factor,
                   paper)


# dmax: the smallest whole number at or above the largest ground-truth disparity.
DATASETS = {d.name: d for d in [
    _v2("tsukuba", "scene1.row3.col3.ppm", "scene1.row3.col4.ppm", "truedisp.row3.col3.pgm",
        16, 15, "384x288", border=18, paper="Tsukuba",
        desc="Middlebury 2001 Tsukuba (head and lamp)"),
    _v2("venus", "im2.ppm", "im6.ppm", "disp2.pgm", 8, 20, "434x383",
        desc="Middlebury 2001 Venus"),
    _v2("sawtooth", "im2.ppm", "im6.ppm", "disp2.pgm", 8, 18, "434x380", masks=False,
        desc="Middlebury 2001 Sawtooth"),
    _v2("cones", "im2.png", "im6.png", "disp2.png", 4, 55, "450x375",
        desc="Middlebury 2003 Cones, quarter size"),
    _v2("teddy", "im2.png", "im6.png", "disp2.png", 4, 53, "450x375",
        desc="Middlebury 2003 Teddy, quarter size"),
    _2006("wood1", "third", 72, "Wood", "457x370"),
    _2006("baby1", "third", 46, "Baby", "413x370"),
    _2006("baby1", "half", 69, "Baby", "620x555"),
    _2006("bowling1", "third", 77, "Bowling", "417x370"),
    _2006("bowling1", "half", 115, "Bowling", "626x555"),
]}

SYNTHETIC = "synthetic"  # generated by csw.synth, always available offline
SYNTHETIC_SIZE = (450, 375)
SYNTHETIC_DMAX = 64


# Said wherever registered files are used without their sha256 check (--no-verify).
NOT_VERIFIED = ("dataset files were not checked against their sha256 (--no-verify); "
                "figures from modified data are not the benchmark's")


class DataError(Exception):
    """Data that can't be found, fetched or verified; the message says what to do."""


def data_dir(explicit=None):
    """The data directory from --data-dir or CSW_DATA_DIR, or None."""
    value = explicit or os.environ.get("CSW_DATA_DIR")
    return Path(value).expanduser() if value else None


def cache_dir():
    import pooch

    return Path(os.environ.get("CSW_CACHE_DIR") or pooch.os_cache("csw"))


def local_path(relpath, explicit_dir=None):
    """Where ``relpath`` already is (data dir, then cache), or None."""
    for root in (data_dir(explicit_dir), cache_dir()):
        if root is not None and (root / relpath).is_file():
            return root / relpath
    return None


def sha256(path):
    digest = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def _url(url):
    mirror = os.environ.get("CSW_DATA_MIRROR")
    if mirror and url.startswith(OFFICIAL_PREFIX):
        return mirror.rstrip("/") + "/" + url[len(OFFICIAL_PREFIX):]
    return url


def download(relpath, progress=False):
    """Fetch one registry file into the cache, verify its sha256, and return its path.

    pooch downloads to a temporary name and renames only after the hash matched, so a
    failed or corrupt download leaves nothing in the cache.  Zip members are extracted
    to a temporary file, hashed, and renamed into place the same way.
    """
    url, digest, member = FILES[relpath]
    url = _url(url)
    target = cache_dir() / relpath
    created = _make_folders(target.parent)
    try:
        return _fetch(relpath, url, digest, member, target, progress)
    except BaseException:
        for folder in reversed(created):  # a failed download leaves no empty folders
            try:
                folder.rmdir()
            except OSError:
                break
        raise


def _make_folders(folder):
    """Create ``folder`` and its missing parents; return those created, outermost first.
    A cache path that can't be used is a DataError that says which and why."""
    missing = []
    probe = folder
    while not probe.exists() and probe != probe.parent:
        missing.append(probe)
        probe = probe.parent
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise DataError(f"the cache folder {folder} can't be created ({exc.strerror or exc}); "
                        "set CSW_CACHE_DIR to a writable folder, or CSW_DATA_DIR / "
                        "--data-dir to one that has the data") from None
    if not os.access(folder, os.W_OK):
        raise DataError(f"the cache folder {folder} is not writable; set CSW_CACHE_DIR to a "
                        "writable folder, or CSW_DATA_DIR / --data-dir to one that has the "
                        "data")
    return list(reversed(missing))


def _fetch(relpath, url, digest, member, target, progress):
    """Download one file (or zip member) to ``target``, verified; see download()."""
    import pooch

    archives = _archive_dir() if member is not None else None
    try:
        if member is None:
            pooch.retrieve(url, known_hash=f"sha256:{digest}", fname=target.name,
                           path=target.parent, progressbar=progress)
            return target
        # The zip's own hash is not published; the member's is, and is checked below.
        archive = pooch.retrieve(url, known_hash=None, fname=Path(url).name,
                                 path=archives, progressbar=progress)
    except ValueError as exc:  # pooch's hash mismatch
        raise DataError(f"{relpath}: download from {url} failed its checksum ({exc}); "
                        "nothing was kept") from None
    except Exception as exc:  # network errors come in many types
        raise DataError(f"{relpath}: can't download {url} ({_network_reason(exc)}); "
                        "set CSW_DATA_DIR or --data-dir to a folder that has the data") from None
    fd, tmp = tempfile.mkstemp(dir=target.parent, prefix=f".{target.name}.")
    os.close(fd)
    try:
        with zipfile.ZipFile(archive) as zf, zf.open(member) as src, open(tmp, "wb") as dst:
            shutil.copyfileobj(src, dst)
        if sha256(tmp) != digest:
            raise DataError(f"{relpath}: member {member} of {url} has the wrong sha256; "
                            "nothing was kept")
        os.replace(tmp, target)
    except (KeyError, zipfile.BadZipFile) as exc:
        raise DataError(f"{relpath}: {url} is not the expected archive ({exc})") from None
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)
    return target


def _network_reason(exc):
    """A download's error in a few words: requests' messages carry the whole chain of
    causes, hundreds of characters of it."""
    text = str(exc)
    for clue, reason in (("resolve", "the host's name can't be resolved: no network?"),
                         ("timed out", "the connection timed out"),
                         ("refused", "the connection was refused"),
                         ("SSL", "a TLS error")):
        if clue in text:
            return reason
    return f"{type(exc).__name__}: {text.splitlines()[0][:80] if text else ''}"


def _archive_dir():
    folder = cache_dir() / "_archives"
    _make_folders(folder)
    return folder


# In the cache: files already checked, by path, size, mtime and ctime (ctime changes with
# any write, even one that restores the mtime).
VERIFIED_FILE = "verified.json"


def _verified_records():
    import json

    try:
        return json.loads((cache_dir() / VERIFIED_FILE).read_text())
    except (OSError, ValueError):
        return {}


def _remember(records):
    """Save the verification records; best effort (a read-only cache just re-hashes)."""
    import json

    from ..io.atomic import atomic_write

    try:
        _make_folders(cache_dir())
        text = json.dumps(records, indent=0, sort_keys=True)
        atomic_write(cache_dir() / VERIFIED_FILE, lambda tmp: Path(tmp).write_text(text))
    except (OSError, DataError):
        pass


def verify(relpath, path):
    """Check a local registry file against its sha256, once: the result is remembered by
    path, size, modification and change times, so later runs cost a stat.  DataError on a mismatch,
    naming the file and how to fix it."""
    digest = FILES[relpath][1]
    stat = path.stat()
    key = str(path.resolve())
    stamp = [digest, stat.st_size, stat.st_mtime_ns, stat.st_ctime_ns]
    records = _verified_records()
    if records.get(key) == stamp:
        return
    if sha256(path) != digest:
        raise DataError(f"{path} does not match the registry's sha256 ({digest[:16]}...): it "
                        "is modified or corrupt. Replace it with the original (or delete it "
                        "to download it again), or pass --no-verify to use it knowingly")
    records[key] = stamp
    _remember(records)


def resolve(relpath, explicit_dir=None, allow_download=True, check=True):
    """Path of a registry file: local if present (verified against its sha256 unless
    ``check`` is False), else downloaded (if allowed), which verifies it."""
    found = local_path(relpath, explicit_dir)
    if found is not None:
        if check:
            verify(relpath, found)
        return found
    if not allow_download:
        raise DataError(f"{relpath} is not in the data directory or the cache; set "
                        "CSW_DATA_DIR or --data-dir, or allow the download")
    return download(relpath)


def is_local(name, explicit_dir=None):
    if name == SYNTHETIC:
        return True
    return all(local_path(f, explicit_dir) for f in DATASETS[name].files)


@dataclass
class Pair:
    """A loaded pair: left/right uint8|uint16 (H, W); gt float32 (H, W), nan unknown;
    masks: region -> bool (H, W) (always has "all"); dmax: the range to search, from the
    data where it says (Middlebury 2014's calib.txt), else one that covers the ground
    truth; dataset: the registry entry, None for a pair read from a folder."""

    name: str
    left: np.ndarray
    right: np.ndarray
    gt: np.ndarray
    masks: dict
    dmax: int
    dataset: Dataset | None = None
    layout: str = "registry"
    verified: bool = True  # False: registry files used without their sha256 check

    def regions(self, border=None):
        """The scoring regions, with ``border`` pixels on every side left out instead of
        the dataset's own border where given."""
        if border is None:
            return dict(self.masks)
        regions = region_masks(np.isfinite(self.gt), border, {})
        regions.update({k: v & regions["all"] for k, v in self.masks.items() if k != "all"})
        return regions


def region_masks(known, border, mask_images):
    """Scoring regions as bool (H, W): "all" is known GT; others from Middlebury masks
    (nonocc: 255; disc: 255 only), always within known GT and outside the border.
    Raises DataError when a mask is not the ground truth's size."""
    for region, image in mask_images.items():
        if image.shape != known.shape:
            raise DataError(f"mask {region!r} is {image.shape[1]}x{image.shape[0]} but the "
                            f"ground truth is {known.shape[1]}x{known.shape[0]}")
    inside = np.zeros_like(known)
    h, w = known.shape
    inside[border:h - border, border:w - border] = True
    regions = {"all": known & inside}
    for region, image in mask_images.items():
        if region == "all":
            continue  # same as known GT for every registry pair
        regions[region] = (image == 255) & known & inside
    return regions


def load(name, explicit_dir=None, allow_download=True, verify=True):
    """Load a registered pair (or the synthetic scene) as a :class:`Pair`.

    verify: check every file against the registry's sha256 (remembered once done);
    False uses modified data knowingly, and the Pair says so (``verified``)."""
    from ..io import ImageError, read_disparity, read_image

    if name == SYNTHETIC:
        from .synth import render

        left, right, gt, nonocc = render(*SYNTHETIC_SIZE, dmax=SYNTHETIC_DMAX, seed=0)
        known = np.isfinite(gt)
        masks = {"all": known, "nonocc": nonocc & known}
        return Pair(name, left, right, gt, masks, SYNTHETIC_DMAX, None)
    if name not in DATASETS:
        raise DataError(f"unknown dataset {name!r}; choose from {', '.join(names())}")
    ds = DATASETS[name]
    try:
        left, right = (read_image(resolve(f, explicit_dir, allow_download, verify))
                       for f in (ds.left, ds.right))
        # Stored value / the dataset's scale = disparity in pixels; 0 is unknown.
        gt = read_disparity(resolve(ds.gt, explicit_dir, allow_download, verify), ds.gt_scale)
        mask_images = {r: read_image(resolve(f, explicit_dir, allow_download, verify))
                       for r, f in ds.masks.items()}
    except ImageError as exc:
        raise DataError(str(exc)) from None
    check_sizes(name, left, right, gt)
    return Pair(name, left, right, gt, region_masks(np.isfinite(gt), ds.border, mask_images),
                ds.dmax, ds, verified=verify)


def check_sizes(name, left, right, gt):
    """A pair whose images and ground truth differ in size can't be scored: say so."""
    sizes = {what: f"{a.shape[1]}x{a.shape[0]}" for what, a in
             (("left", left), ("right", right), ("ground truth", gt))}
    if len(set(sizes.values())) > 1:
        raise DataError(f"{name}: the files differ in size ("
                        + ", ".join(f"{k} {v}" for k, v in sizes.items()) + ")")


def names():
    return [SYNTHETIC, *DATASETS]
