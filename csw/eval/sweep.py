"""CSW's trade-off between work saved and accuracy, over tau, rules and the unique
rule's margin."""

from ..config.params import OFF_STAGES, csw_margin_for
from ..config.tau import paper_tau, sweep_value
from ..matching.pipeline import run as run_pipeline
from .bench import RULE_LABELS
from .scoring import bad1_all, score

DEFAULT_TAUS = "0.25x,0.5x,1x,1.5x,2x,3x,5x,none"


def sweep_rows(pair, *, cost, rules, taus, csw_margins=(None,), window, dmax, threads=None,
               progress=None, stages=OFF_STAGES):
    """Plain matching, then every (rule, csw_margin, tau) with CSW, as dicts.

    taus: (label, kind, number) items from :func:`csw.config.tau.parse_sweep`.  stages: the
    pipeline's stages around every run (off: the raw maps).
    Results are the same with either engine; the sweep uses the fast one.
    """
    progress = progress or (lambda step: None)
    settings = dict(engine="fast", window=window, dmin=0, dmax=dmax, cost=cost,
                    threads=threads)
    plain_map, _, plain = run_pipeline(pair.left, pair.right, dict(settings, csw=False, tau=-1),
                                       stages)
    plain_bad1 = bad1_all(plain_map, pair)
    auto = paper_tau(plain.min_cost)

    def row(disp, result, rule, csw_margin, label, tau):
        metrics = score(disp, pair.gt, pair.masks, (1.0,))
        name = RULE_LABELS[rule]
        if rule == "unique" and csw_margin is not None:
            name += f" U={csw_margin}"
        return {"dataset": pair.name, "cost": cost, "rule": rule, "csw_margin": csw_margin,
                "algorithm": cost.upper() + name, "tau_label": label, "tau": tau,
                "auto_tau": auto, "window": window, "dmax": dmax,
                "work_saved": 100.0 * result.work_saved if rule else None,
                "error_rate": metrics["all"]["bad"][1.0],
                "delta": metrics["all"]["bad"][1.0] - plain_bad1 if rule else None,
                "nonocc": metrics.get("nonocc", {}).get("bad", {}).get(1.0)}

    rows = [row(plain_map, plain, None, None, "", None)]
    for rule in rules:
        for csw_margin in (csw_margins if rule == "unique" else [None]):
            for label, kind, number in taus:
                tau = sweep_value(kind, number, auto)
                progress(f"{pair.name} {cost.upper()} {rule} tau {label}")
                disp, _, result = run_pipeline(
                    pair.left, pair.right,
                    dict(settings, csw=True, tau=tau, rule=rule,
                         csw_margin=csw_margin_for(cost, csw_margin)), stages)
                rows.append(row(disp, result, rule, csw_margin, label, tau))
    return rows
