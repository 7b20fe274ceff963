"""Every matching option in one table: its default, its allowed values, its help, and the
presets over it.  ``csw.match``, the tiled and batch entries, the experiments and every
command's options read this table, so a default, a choice list or a range is written
here once (the CLI builds its Click options from it: csw_cli/options.py).

``resolve(**given)`` turns what a caller gave into a :class:`Config`, the one typed record
everything below the edge takes: the given values over the preset's over the defaults,
each checked and normalised (``"off"`` becomes None, ``"3"`` becomes 3, a tau word stays a
word).  Unknown names are a TypeError, bad values a ValueError whose message says how to
fix them.
"""

import math
from dataclasses import asdict, dataclass, replace

from ..kernels.contract import (
    CENSUS_PATTERNS,
    COSTS,
    ENGINE_NAMES,
    RULES,
)
from .paper import WINDOW as PAPER_WINDOW


class OptionError(ValueError):
    """A bad value for one named option or argument; ``option`` is its name (the CLI
    turns it into its flag)."""

    def __init__(self, option, message):
        super().__init__(message)
        self.option = option


@dataclass(frozen=True)
class Option:
    """One matching option.

    kind: how values are read and checked:
      choice   one of ``choices`` (strings)
      int      a whole number in [low, high] (``odd``: odd only)
      float    a number in [low, high]
      bool     True or False
      off_int  None ("off") or a whole number in [low, high]
      auto_int None (the derived default ``default_text`` names) or a whole number
      int_auto a whole number, or "auto" (found from the pair)
      tau      a tau as csw.config.tau reads it (a number >= 0, "auto", "none"), or None
    stage: a pipeline stage around the kernels (csw.matching.pipeline), off in the paper's contract.
    flag: the command-line flag, where it differs from --name-with-dashes.
    """

    name: str
    kind: str
    default: object
    help: str
    choices: tuple = ()
    low: float | None = None  # for int and float kinds
    high: float | None = None
    odd: bool = False
    stage: bool = False
    default_text: str | None = None  # what the help says of the default, when not the value
    flag: str | None = None

    @property
    def cli_flag(self):
        return self.flag or "--" + self.name.replace("_", "-")

    def check(self, value):
        """The value normalised, or ValueError saying what is allowed."""
        name = self.name
        if self.kind == "choice":
            text = str(value).strip().lower() if isinstance(value, str) else value
            if text not in self.choices:
                raise ValueError(f"{name} must be one of {', '.join(map(str, self.choices))}, "
                                 f"got {value!r}")
            return text
        if self.kind == "bool":
            if not isinstance(value, (bool, int)) or value not in (0, 1):
                raise ValueError(f"{name} must be True or False, got {value!r}")
            return bool(value)
        if self.kind == "tau":
            from .tau import parse_tau

            return parse_tau(value, ("auto", "none"))
        if self.kind == "int_auto" and isinstance(value, str) and \
                value.strip().lower() == "auto":
            return "auto"
        if value is None and self.kind in ("off_int", "auto_int"):
            return None
        if self.kind == "off_int" and isinstance(value, str) and value.strip().lower() == "off":
            return None
        if self.kind == "float":
            number = _number(name, value)
        else:
            number = _whole(name, value, self.kind == "off_int")
        if (self.low is not None and number < self.low) or \
                (self.high is not None and number > self.high):
            raise ValueError(f"{name} must be {self.range_text()}, got {value!r}")
        if self.choices and number not in self.choices:
            raise ValueError(f"{name} must be one of {', '.join(map(str, self.choices))}, "
                             f"got {value!r}")
        if self.odd and number % 2 == 0:
            raise ValueError(f"{name} must be odd (e.g. {self.default}), got {number}")
        return number

    def range_text(self):
        """The allowed values, in words: 'from 1 to 63', '>= 0', 'odd, from 3 to 7'."""
        if self.low is not None and self.high is not None:
            text = f"from {self.low:g} to {self.high:g}"
        elif self.low is not None:
            text = f">= {self.low:g}"
        else:
            text = "a number"
        text = ("odd, " + text) if self.odd else text
        return text + (", or off" if self.kind == "off_int" else "")


def _whole(name, value, off=False):
    if isinstance(value, bool):
        raise ValueError(f"{name} must be a whole number, got {value!r}")
    try:
        number = float(value) if isinstance(value, str) else value
        if number != int(number):
            raise ValueError
        return int(number)
    except (TypeError, ValueError, OverflowError):
        more = " or 'off'" if off else ""
        raise ValueError(f"{name} must be a whole number{more}, got {value!r}") from None


def _number(name, value):
    if isinstance(value, bool):
        raise ValueError(f"{name} must be a number, got {value!r}")
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a number, got {value!r}") from None
    if not math.isfinite(number):
        raise ValueError(f"{name} must be a finite number, got {value!r}")
    return number


# The census without a preset's: a dense 5x5 window (24 bits).
DEFAULT_CENSUS_WINDOW, DEFAULT_CENSUS_PATTERN = 5, "dense"
# The unique rule's margin in percent, by cost, where none is given: chosen on the
# registered datasets (reports/csw-tradeoff.md); SSD's squared costs need a wider one.
DEFAULT_CSW_MARGIN = {"sad": 12, "ssd": 25, "shd": 12, "census": 12}

# What the help says of the unique rule's default margin: "12; 25 for SSD".
CSW_MARGIN_TEXT = "; ".join([str(DEFAULT_CSW_MARGIN["sad"])] + [
    f"{v} for {k.upper()}" for k, v in DEFAULT_CSW_MARGIN.items()
    if v != DEFAULT_CSW_MARGIN["sad"]])

RULE_HELP = ("literal: the paper's rule, a match with m <= tau claims its right pixel for "
             "good. unique: only distinct matches claim, and a claim does not bind the next "
             "pixel; it keeps plain matching's accuracy (see reports/csw-tradeoff.md).")
ENGINE_HELP = ("fast: running sums, O(1) per (pixel, disparity); window: a full window sum "
               "per candidate, the paper's method, where CSW's skipped candidates save real "
               "time. Both give identical results.")

# More threads than any machine csw runs on has cores: a larger number is a mistake, refused
# with the options rather than when a frame's stripes are planned.
MAX_THREADS = 1024

OPTIONS = {o.name: o for o in [
    # The default is the most accurate preset whose time on a 1920x1080 pair at d 0..255,
    # every core, is at most OpenCV SGBM's on one thread (reports/quality.md and
    # reports/sgm.md measure both).
    Option("preset", "choice", "sgm", choices=("sgm", "accurate", "camera", "raw", "paper"),
           help="sgm: semi-global matching on census costs, for maps dense enough to drive "
                "on; accurate: census, left-right check and speckle removal, local windows "
                "only: a quarter of sgm's time, with holes where sgm fills; camera: "
                "StereoBM's x-Sobel SAD, its left-right check and speckle removal, for "
                "camera rates: denser and lower in filled error than StereoBM with its "
                "filters; raw: the contract's winner-take-all map; paper: the paper's "
                "method (window engine, SAD 9x9, no stage)."),
    Option("engine", "choice", "fast", choices=ENGINE_NAMES, help=ENGINE_HELP),
    Option("cost", "choice", "sad", choices=tuple(COSTS),
           help="Matching cost: sad, ssd, shd, or census (census codes compared by Hamming "
                "distance)."),
    Option("window", "int", 9, low=1, odd=True,
           help="Odd window side (9 = the paper's 9x9)."),
    Option("dmin", "int_auto", 0,
           help="Smallest disparity searched; below 0 for convergent rigs and satellite "
                "pairs; 'auto' finds it from the pair."),
    Option("dmax", "int_auto", "auto",
           help="Largest disparity searched (less than the width), or 'auto': found from "
                "the pair (a coarse match of the shrunk pair, a few percent of the time)."),
    Option("csw", "bool", False,
           help="Skip right pixels already claimed by a confident match."),
    Option("csw_rule", "choice", "literal", choices=tuple(RULES), help=RULE_HELP),
    Option("tau", "tau", None, default_text="auto for the literal rule, none for the unique "
                                            "rule",
           help="CSW threshold on the minimum cost: a number, 'auto' for the paper's rule "
                "(width of the first of 10 histogram bins), or 'none'. Needs --csw."),
    Option("csw_margin", "auto_int", None, low=0, high=1000, default_text=CSW_MARGIN_TEXT,
           help="The unique rule's margin in percent: the best cost must beat every "
                "candidate 2 or more disparities away by this much."),
    Option("threads", "auto_int", None, low=1, high=MAX_THREADS, default_text="all cores",
           help="Threads for row-parallel matching."),
    # The pipeline's stages (csw.matching.pipeline), all off in the paper's contract.
    Option("prefilter", "choice", "none", choices=("none", "xsobel"), stage=True,
           help="xsobel: StereoBM's x-Sobel prefilter, clipped to +-cap."),
    Option("prefilter_cap", "int", 31, low=1, high=63, stage=True,
           help="The prefilter's cap (StereoBM's range)."),
    Option("census_window", "int", DEFAULT_CENSUS_WINDOW, low=3, odd=True, stage=True,
           help="Census window side for --cost census (odd; at most 7 dense, 15 sparse, "
                "for 64 bits)."),
    Option("census_pattern", "choice", DEFAULT_CENSUS_PATTERN, choices=CENSUS_PATTERNS,
           stage=True,
           help="Which neighbours make census bits: dense, all of them; sparse, every "
                "second pixel of every second row and the centre's 8 neighbours (a 9x9 "
                "window in 32 bits)."),
    Option("aggregate", "choice", "none", choices=("none", "sgm"), stage=True,
           help="sgm: semi-global matching, the window costs aggregated along paths "
                "(Hirschmueller's), for maps dense where local windows leave holes."),
    Option("sgm_paths", "int", 4, choices=(4, 5, 8), stage=True,
           help="Semi-global paths: 4 (left, right, up, down), 5 (left, right, down and the "
                "two diagonals going down, as OpenCV SGBM's default: one sweep, no second "
                "pass) or 8 (all of them)."),
    Option("sgm_p1", "auto_int", None, low=0, high=10**7, stage=True,
           default_text="scaled to the cost: a quarter of the census bits per window pixel, "
                        "8 per window pixel for SAD",
           help="Semi-global penalty for a disparity step of 1 along a path."),
    Option("sgm_p2", "auto_int", None, low=0, high=10**7, stage=True,
           default_text="4 x the default P1",
           help="Semi-global penalty for a larger disparity step (at least P1)."),
    Option("sgm_narrow", "int", 0, low=0, high=32767, stage=True,
           help="Semi-global matching's narrowed search: a half-size pass first, then each "
                "pixel aggregates only N disparities around its half-size match (0: every "
                "disparity of the range; the sgm preset: 64)."),
    Option("lr_check", "off_int", None, low=0, high=10**9, stage=True,
           help="Left-right check from the same costs: invalid where the right image's "
                "match differs by more than N; 'off' to drop it."),
    Option("winner_check", "off_int", None, low=0, high=10**9, stage=True,
           help="StereoBM's left-right check (its disp12MaxDiff): a right pixel's match "
                "is the left pixel that chose it at the least cost; invalid where that "
                "differs by more than N.  Two passes of the winners, where --lr-check's "
                "right map takes a pass over the range per pixel; denser than it too."),
    Option("uniqueness_ratio", "off_int", None, low=0, high=10**9, stage=True,
           help="StereoBM's: invalid where a candidate 2+ away costs within N% of the best."),
    Option("texture_threshold", "off_int", None, low=0, high=10**9, stage=True,
           help="StereoBM's: invalid where the window's summed |x-Sobel| is below N."),
    Option("subpixel", "choice", "none", choices=("none", "parabola", "linear"), stage=True,
           help="Subpixel fit through the costs at d-1, d, d+1."),
    Option("speckle_size", "int", 0, low=0, high=10**7, stage=True,
           help="Invalidate regions of similar disparity under N pixels (0: off)."),
    Option("speckle_range", "float", 1.0, low=0, high=1000, stage=True,
           help="Largest step between neighbours of one speckle region."),
    Option("median", "int", 0, choices=(0, 3, 5, 7), stage=True,
           help="A KxK median over valid pixels (0: off)."),
    Option("fill", "choice", "none", choices=("none", "background"), stage=True,
           help="background: fill invalid pixels as the Middlebury/KITTI kits do."),
]}

# The pipeline's stages with their "off" values: the paper's contract.
STAGE_NAMES = tuple(name for name, o in OPTIONS.items() if o.stage)
OFF = {name: OPTIONS[name].default for name in STAGE_NAMES}
DEFAULTS = {name: o.default for name, o in OPTIONS.items()}

# The paper preset's range, and the experiments' (bench, hist) when a pair has none: fixed,
# so that TABLE II and the timing reports search what they always searched.
FIXED_DMAX = 64

PRESETS = {
    # The paper's method exactly, what TABLE II measures: no stage may be added to it.
    "paper": {"engine": "window", "cost": "sad", "window": PAPER_WINDOW, "dmax": FIXED_DMAX,
              **OFF},
    # The contract's raw winner-take-all map, with the engine and cost as given.
    "raw": {**OFF},
    # The pipeline recommended for real photographs, one setting for every dataset
    # (reports/quality.md has the measurements): a sparse 9x9 census (32-bit codes, where
    # dense 7x7 needs 64-bit ones: the whole match takes about a quarter less time at
    # 1080p, and every dataset's map is denser) over a 9x9 window, the left-right check
    # at 2, and speckles under 100 pixels removed.
    "accurate": {**OFF, "cost": "census", "census_window": 9, "census_pattern": "sparse",
                 "lr_check": 2, "speckle_size": 100, "speckle_range": 1.0},
    # Camera rates (reports/stream.md, reports/quality.md): the cheapest stages found
    # whose map is denser and lower in filled error than StereoBM with its own filters
    # (uniqueness 15, speckles 100/32, disp12MaxDiff 1) on every registered pair.
    # StereoBM's x-Sobel prefilter on SAD 7x7 (9x9 left Tsukuba's filled error above
    # StereoBM's), StereoBM's left-right check at 1 and speckles under 50 pixels: without
    # a check, or without the speckle filter, some pair falls behind StereoBM.  Its
    # check from the winners is denser than the exact one (KITTI: 50% against 44%) at
    # about the same filled error, and costs a fifth of the match less.
    "camera": {**OFF, "cost": "sad", "window": 7, "prefilter": "xsobel", "winner_check": 1,
               "speckle_size": 50, "speckle_range": 1.0},
    # Semi-global matching for maps dense enough to drive on (reports/quality.md): the
    # same sparse 9x9 census summed over a 3x3 window (denser than each pixel's own
    # code: 90% against 82% on the KITTI pairs), aggregated along 4 paths with the
    # penalties scaled to it (8 paths smeared more wrong values into patches that
    # survive the checks), the left-right check at 1, a parabola through the aggregated
    # costs, speckles under 400 pixels (steps of 2) removed and a 3x3 median.  A 5x5
    # window is denser (92% on KITTI) and lower in KITTI's mean filled error (4.53%
    # against 4.79), but it carries matches across edges: higher in bad over valid on
    # every registered pair, and in filled error above the accurate preset on cones and
    # baby1-half.  Ranges wider than 64 are narrowed to 64 disparities a pixel after a
    # half-size pass: as dense or denser on every pair of reports/quality.md, faster,
    # and as low or lower in filled error but on six pairs (at most +0.4 point: KITTI
    # 2015 000001, bowling1-half; the KITTI mean 4.79 against 4.83 whole;
    # docs/engines.md, "Narrowed search").
    "sgm": {**OFF, "cost": "census", "census_window": 9, "census_pattern": "sparse",
            "window": 3, "aggregate": "sgm", "sgm_paths": 4, "lr_check": 1,
            "subpixel": "parabola", "speckle_size": 400, "speckle_range": 2.0, "median": 3,
            "sgm_narrow": 64},
}
# The experiments (bench, sweep, hist) study the kernels' maps unless told otherwise.
EXPERIMENT_PRESET = "raw"
# Experiments time and score on one thread, the paper's setting, unless told.
BENCH_THREADS = 1
BENCH_REPEAT = 5


def check(name, value):
    """One option's value, normalised; OptionError (a ValueError) when not allowed."""
    try:
        return OPTIONS[name].check(value)
    except ValueError as exc:
        raise OptionError(name, str(exc)) from None


@dataclass(frozen=True)
class Stages:
    """The pipeline's stages around the kernels (csw.matching.pipeline), as resolved: each
    field is the option of that name (OPTIONS has its help); all off is the paper's
    contract (:data:`OFF_STAGES`)."""

    prefilter: str
    prefilter_cap: int
    census_window: int
    census_pattern: str
    aggregate: str
    sgm_paths: int
    sgm_p1: int | None
    sgm_p2: int | None
    sgm_narrow: int
    lr_check: int | None
    winner_check: int | None
    uniqueness_ratio: int | None
    texture_threshold: int | None
    subpixel: str
    speckle_size: int
    speckle_range: float
    median: int
    fill: str

    def changed(self):
        """The stages that are not off: name -> value."""
        return {k: v for k, v in asdict(self).items() if v != OFF[k]}


OFF_STAGES = Stages(**OFF)  # the paper's contract: no stage


@dataclass(frozen=True)
class Config:
    """Every matching option, resolved once (:func:`resolve`) at the edge (the CLI,
    ``csw.match``, ``csw.Matcher``): what everything below takes.  Each field is the
    option of that name (OPTIONS has its help), except:

    csw_margin: the unique rule's margin, its per-cost default applied.
    stages: the pipeline's stages (:class:`Stages`).
    given: the names the caller gave (the rest came from the preset or the defaults).
    range_source: where dmin and dmax came from (csw.matching.disparity_range.decide):
        "given", "default", "ndisp of FILE", "auto", or "auto (from the first pair)".
    """

    preset: str
    engine: str
    cost: str
    window: int
    dmin: int | str  # a number, or "auto" until the range is decided
    dmax: int | str
    csw: bool
    csw_rule: str
    tau: object  # a number >= 0, "auto", "none", or None (the rule's default)
    csw_margin: int
    threads: int | None
    stages: Stages
    given: frozenset = frozenset()
    range_source: str = "default"

    def replace(self, **changes):
        """A copy with ``changes`` (fields, or stage names)."""
        staged = {k: changes.pop(k) for k in list(changes) if k in OFF}
        if staged:
            changes["stages"] = replace(self.stages, **staged)
        return replace(self, **changes)

    @property
    def range_known(self):
        return "auto" not in (self.dmin, self.dmax)

    def as_dict(self):
        """Every option by name, flat (the stages beside the others), and range_source:
        what results report as their settings."""
        stages = asdict(self.stages)
        return {**{name: stages[name] if name in stages else getattr(self, name)
                   for name in OPTIONS}, "range_source": self.range_source}

    def kernel_args(self):
        """The kernels' keyword arguments (csw.kernels.match) but for CSW and tau, which
        the match resolves."""
        return dict(engine=self.engine, window=self.window, dmin=self.dmin, dmax=self.dmax,
                    cost=self.cost, rule=self.csw_rule, csw_margin=self.csw_margin,
                    threads=self.threads)


def resolve(**given):
    """The :class:`Config` of ``given``: over its preset over the defaults, every value
    checked and normalised.  TypeError for an unknown name; ValueError for a bad value, a
    stage added to the paper preset, or an option that does nothing without CSW."""
    unknown = set(given) - set(OPTIONS)
    if unknown:
        raise TypeError(f"unknown option(s) {', '.join(sorted(unknown))}; "
                        f"csw.match takes {', '.join(OPTIONS)}")
    given = {k: check(k, v) for k, v in given.items()}
    preset = given.get("preset", DEFAULTS["preset"])
    if preset == "paper":
        added = [k for k in OFF if k in given and given[k] != OFF[k]]
        if added:
            raise ValueError(f"the paper preset is the paper's raw method; drop "
                             f"{', '.join(added)} (or use another preset)")
    opts = {**DEFAULTS, **PRESETS[preset], **given}
    opts["csw_margin"] = csw_margin_for(opts["cost"], opts["csw_margin"])
    if "auto" not in (opts["dmin"], opts["dmax"]) and opts["dmin"] > opts["dmax"]:
        raise OptionError("dmin", f"dmin ({opts['dmin']}) must not exceed dmax "
                                  f"({opts['dmax']})")
    check_acts(opts, given)
    check_sgm_use(opts, given)
    stages = Stages(**{k: opts.pop(k) for k in OFF})
    range_source = "given" if {"dmin", "dmax"} & set(given) else \
        "default" if "auto" not in (opts["dmin"], opts["dmax"]) else "auto"
    return Config(**opts, stages=stages, given=frozenset(given), range_source=range_source)


def csw_margin_for(cost, given=None):
    """The unique rule's margin: as given, or the cost's default."""
    return DEFAULT_CSW_MARGIN[cost] if given is None else given


# Options that act only with another setting: name -> (whether it acts, given every
# resolved option; what it needs; what to add).  One given that would do nothing is
# refused rather than ignored: a user who forgot --csw, or gave a census window to SAD,
# would otherwise get a different match than the one asked for.
_CSW = (lambda o: o["csw"], "CSW on", "csw=True (--csw)")
_SGM = (lambda o: o["aggregate"] == "sgm", "aggregate='sgm' (--aggregate sgm)", "it")
_CENSUS = (lambda o: o["cost"] == "census", "cost='census' (--cost census)", "it")
ACTS_ONLY_WITH = {
    "csw_rule": _CSW, "tau": _CSW, "csw_margin": _CSW,
    "sgm_paths": _SGM, "sgm_p1": _SGM, "sgm_p2": _SGM, "sgm_narrow": _SGM,
    "census_window": _CENSUS, "census_pattern": _CENSUS,
    "speckle_range": (lambda o: o["speckle_size"] > 0, "a speckle_size above 0",
                      "--speckle-size"),
    "prefilter_cap": (lambda o: o["prefilter"] == "xsobel" or
                      o["texture_threshold"] is not None,
                      "prefilter='xsobel' (--prefilter xsobel) or a texture_threshold",
                      "one"),
}


def check_acts(opts, given):
    """Refuse a given option that would do nothing (ACTS_ONLY_WITH), unless it is given
    its default, which changes nothing either way."""
    for name, (acts, needs, fix) in ACTS_ONLY_WITH.items():
        if given.get(name, OPTIONS[name].default) != OPTIONS[name].default and \
                not acts(opts):
            raise OptionError(name, f"{name} applies only with {needs}; add {fix} or drop "
                                    f"{name}")


def check_sgm_use(opts, given):
    """Refuse what semi-global matching can't take: CSW (its skips are local matching's),
    the window engine, or P1 above P2."""
    if opts["aggregate"] != "sgm":
        return
    if opts["csw"]:
        raise OptionError("csw", "CSW skips candidates of local matching; semi-global "
                                 "matching (aggregate='sgm', the sgm preset's) needs every "
                                 "cost: with csw choose a local preset (--preset accurate, "
                                 "raw or paper) or aggregate='none'")
    if opts["engine"] != "fast" and "engine" in given:
        raise OptionError("engine", "semi-global matching computes its own costs; drop "
                                    "engine='window' or aggregate='sgm'")
    p1, p2 = opts["sgm_p1"], opts["sgm_p2"]
    if p1 is not None and p2 is not None and p1 > p2:
        raise OptionError("sgm_p1", f"sgm_p1 ({p1}) must not exceed sgm_p2 ({p2})")


def experiment_stages(**given):
    """The stages of an experiment (bench, sweep): ``preset`` (default: the experiments'
    raw) and stage options over it, checked as for :func:`resolve`."""
    given.setdefault("preset", EXPERIMENT_PRESET)
    return resolve(**given).stages
