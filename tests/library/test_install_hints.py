"""Every `pip install` hint in the code and the docs names something that installs csw's
own extras: the distribution pyproject.toml names, or a checkout ('.'). PyPI's "csw" is
an unrelated project, so a hint naming it installs the wrong thing."""

import re
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
PROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
HINT = re.compile(r"pip install\s+['\"`]?([A-Za-z0-9_.-]+)(\[[^\]]*\])?")
SOURCES = [ROOT / "README.md", ROOT / "Makefile",
           *(path for folder in ("csw", "csw_cli", "kernels", "scripts", "docs")
             for path in sorted((ROOT / folder).rglob("*"))
             if path.suffix in {".py", ".sh", ".md"})]


def hints():
    for path in SOURCES:
        for found in HINT.finditer(path.read_text()):
            yield path.relative_to(ROOT), found.group(1), found.group(2)


def test_the_distribution_is_not_pypis_csw():
    assert PROJECT["name"] != "csw"
    assert PROJECT["scripts"]["csw"] == "csw_cli.main:main"


def test_every_hint_for_an_extra_names_the_distribution_or_a_checkout():
    extras = set(PROJECT["optional-dependencies"])
    wrong = [(str(path), name, wanted) for path, name, wanted in hints()
             if name == "csw" or (wanted and name not in {PROJECT["name"], "."})
             or (wanted and not set(wanted.strip("[]").split(",")) <= extras)]
    assert wrong == []


def test_the_hints_are_found():
    named = {name for _, name, wanted in hints() if wanted}
    assert PROJECT["name"] in named  # the runtime errors name it (video, Dask, plots)


def test_the_extras_name_the_distribution_itself():
    own = [extra for extra in sum(PROJECT["optional-dependencies"].values(), [])
           if re.match(r"csw\b", extra)]
    assert own and all(extra.startswith(PROJECT["name"] + "[") for extra in own)
