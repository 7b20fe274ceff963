"""The report generators in scripts/ run only in `make bench*`, `make quality` and
`make tradeoff`; each is at least importable against the library as it stands, so a
renamed or removed name fails here rather than at the next report."""

import importlib.util
import json
import re
import sys
from pathlib import Path

import pytest

SCRIPTS = Path(__file__).parents[2] / "scripts"


def load_script(name, monkeypatch):
    """scripts/NAME.py imported, module level only (each report runs under __main__)."""
    path = SCRIPTS / f"{name}.py"
    monkeypatch.syspath_prepend(str(SCRIPTS))
    spec = importlib.util.spec_from_file_location(f"_script_{name}", path)
    module = importlib.util.module_from_spec(spec)
    monkeypatch.setitem(sys.modules, spec.name, module)
    spec.loader.exec_module(module)
    return module


@pytest.mark.parametrize("path", sorted(SCRIPTS.glob("*.py")), ids=lambda p: p.name)
def test_every_report_script_imports(path, monkeypatch):
    load_script(path.stem, monkeypatch)


def test_the_stream_report_rewritten_from_its_figures_is_the_committed_one(monkeypatch):
    """The report's prose is scripts/templates/stream.md; its figures, reports/stream.json.
    Filled in again, they give reports/stream.md as committed (OpenCV's version is the
    one recorded there)."""
    report = load_script("stream_report", monkeypatch)
    committed = (SCRIPTS.parent / "reports" / "stream.md").read_text()
    data = __import__("json").loads((SCRIPTS.parent / "reports" / "stream.json").read_text())
    data["notes"] = report.notes(data)
    version = committed.split("; OpenCV ", 1)[1].split(".\n", 1)[0]
    monkeypatch.setattr(report.cv2, "__version__", version)
    assert report.markdown(data) == committed


def committed_date(text):
    """The date a report was made, as now_utc() wrote it there."""
    return re.search(r"\d{4}-\d\d-\d\d \d\d:\d\d UTC", text).group()


def test_the_rectify_report_rewritten_from_its_figures_is_the_committed_one(monkeypatch):
    """reports/rectify.json keeps the timings; filled into scripts/templates/rectify.md
    they give reports/rectify.md as committed (its chessboard section, measured on a
    dataset, is taken from it as it stands)."""
    report = load_script("rectify_report", monkeypatch)
    committed = (SCRIPTS.parent / "reports" / "rectify.md").read_text()
    data = json.loads((SCRIPTS.parent / "reports" / "rectify.json").read_text())
    chessboard = committed[committed.index("## Real chessboard pairs"):]
    assert report.markdown(data["rows_seconds"], data["ratios"], committed_date(committed),
                           chessboard) == committed


def test_the_first_photo_report_rewritten_from_its_figures_is_the_committed_one(
        monkeypatch):
    report = load_script("first_photo", monkeypatch)
    committed = (SCRIPTS.parent / "reports" / "first-photo.md").read_text()
    records = json.loads((SCRIPTS.parent / "reports" / "first-photo.json").read_text())
    assert report.markdown(records, committed_date(committed)) == committed


def test_every_template_block_is_used_and_every_field_filled(monkeypatch):
    """Each template is filled by one script (fill_template("NAME", ...)); a block that
    script never names, or a field it never sets, fails here rather than at the next
    (long) report run."""
    common = load_script("report_common", monkeypatch)
    import string

    scripts = {path: path.read_text() for path in SCRIPTS.glob("*.py")}
    for template in sorted((SCRIPTS / "templates").glob("*.md")):
        users = [text for text in scripts.values()
                 if f'fill_template("{template.stem}"' in text]
        assert len(users) == 1, f"{template.name} is filled by {len(users)} scripts"
        blocks = common.template_blocks(template.stem)
        assert blocks, template
        for name, text in blocks.items():
            assert f'"{name}"' in users[0], f"{template.name}: block {name} is never used"
            for field in {f for _, f, _, _ in string.Formatter().parse(text) if f}:
                assert f"{field}=" in users[0], \
                    f"{template.name}: {{{field}}} is never filled"
