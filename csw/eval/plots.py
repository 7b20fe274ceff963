"""Figures for the reports and commands (matplotlib, an optional extra: ``csw[plot]``)."""

from ..io.atomic import atomic_write


def pyplot():
    """matplotlib.pyplot on the file-only Agg backend; ImportError saying how to get it."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        raise ImportError("plots need matplotlib: pip install 'csw-stereo[plot]' "
                          "(from a checkout: '.[plot]')") from None
    return plt


def save_figure(fig, path, dpi=110):
    """Write a figure as PNG atomically, then free it."""
    atomic_write(path, lambda tmp: fig.savefig(tmp, format="png", dpi=dpi))
    pyplot().close(fig)


def histogram(path, min_cost, tau, title):
    """The min-cost histogram (the paper's Fig. 9) with the tau its rule picks."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6, 3.5))
    ax.hist(min_cost[min_cost >= 0].ravel(), bins=10, color="#4878a8", edgecolor="white")
    ax.axvline(tau, color="#c03030", linestyle="--", label=f"paper's tau = {tau:g}")
    ax.set_xlabel("minimum cost m")
    ax.set_ylabel("pixels")
    ax.set_title(title)
    ax.legend()
    fig.tight_layout()
    save_figure(fig, path, dpi=120)


def tradeoff(path, rows, title):
    """Work saved (x) against bad-1 (y) from csw.sweep rows: one curve per rule and
    margin, the plain row as a dashed line."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    plain = rows[0]["error_rate"]
    ax.axhline(plain, color="#555555", linestyle="--", label=f"plain ({plain:.2f}%)")
    curves = {}
    for r in rows[1:]:
        curves.setdefault(r["algorithm"], []).append(r)
    for label, points in curves.items():
        xs = [p["work_saved"] for p in points]
        ys = [p["error_rate"] for p in points]
        ax.plot(xs, ys, marker="o", label=label)
        for p in points:
            ax.annotate(p["tau_label"], (p["work_saved"], p["error_rate"]), fontsize=7,
                        textcoords="offset points", xytext=(3, 3))
    # Keep the interesting range readable: literal CSW with a huge tau goes off the chart.
    top = max(r["error_rate"] for r in rows)
    limit = min(top, 2.5 * plain + 5)
    ax.set_ylim(min(r["error_rate"] for r in rows) - 1, limit + 1)
    if top > limit + 1:
        ax.text(0.01, 0.98, "points above the chart are left out of view", fontsize=7,
                transform=ax.transAxes, va="top")
    ax.set_xlabel("work saved (% of candidate costs skipped)")
    ax.set_ylabel("bad-1 over all known ground truth (%)")
    ax.set_title(title)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    save_figure(fig, path, dpi=110)


