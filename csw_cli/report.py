"""Printing tables: one function for every command, in every --format."""

import csv
import io
import json
import math

import click
from tabulate import tabulate

TABULATE_FORMATS = {"table": "simple", "github": "github", "latex": "latex"}


def _cell(value, digits):
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return ""
    if value == math.inf:  # a threshold that is not set, such as tau none
        return "none"
    if isinstance(value, float):
        return f"{value:.{digits}f}"
    return value


def emit(records, columns, fmt, caption=None):
    """Print ``records`` (list of dicts) to stdout in ``fmt``.

    columns: (key, header, digits) for the human formats (table, github, latex, csv).
    json prints the records themselves, whole, with sorted keys.
    The caption goes above human tables, and to stderr for csv and json so that stdout
    stays machine-readable.
    """
    if fmt == "json":
        if caption:
            click.echo(caption, err=True)
        click.echo(json.dumps(_clean(records), indent=2, sort_keys=True,
                              default=_json_default, allow_nan=False))
        return
    rows = [[_cell(r.get(key), digits) for key, _, digits in columns] for r in records]
    headers = [header for _, header, _ in columns]
    if fmt == "csv":
        if caption:
            click.echo(caption, err=True)
        buffer = io.StringIO()
        writer = csv.writer(buffer, lineterminator="\n")
        writer.writerow(headers)
        writer.writerows(rows)
        click.echo(buffer.getvalue(), nl=False)
        return
    if caption:
        click.echo(caption + "\n")
    click.echo(tabulate(rows, headers=headers, tablefmt=TABULATE_FORMATS[fmt],
                        disable_numparse=True))


def _clean(value):
    """NaN is not JSON: report it as null."""
    if isinstance(value, dict):
        return {str(k): _clean(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_clean(v) for v in value]
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def _json_default(value):
    if hasattr(value, "item"):  # numpy scalars
        return value.item()
    raise TypeError(f"not JSON serialisable: {type(value).__name__}")
