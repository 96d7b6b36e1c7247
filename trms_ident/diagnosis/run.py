"""diagnose(log) -> Diagnosis, top to bottom: the effect search (search.py) finds what the seed model leaves
out, the rule (weigh.py) sets it beside the known values off their table, and findings whose model simulates an
axis worse on held-out samples (held_out.py) are refused and the search run again without them."""
from __future__ import annotations

from dataclasses import replace
from typing import Callable

import numpy as np

from ..log import Log
from ..model.structure import of_bench
from ..params import KNOWN, merge
from . import held_out, search
from .result import VERDICTS, Diagnosis
from .verdict import STAND_IN, stand_in_sentence, stand_ins
from .weigh import weigh


def diagnose(log: Log, overrides: dict | None = None, law: str = "quadratic", a_rad_s: float | None = None,
             progress: Callable[[str, float], None] | None = None, seed=None) -> Diagnosis:
    """Find what the seed model leaves out of this log, fit it, and give the verdict (VERDICTS).

    ``overrides``: the bench's known values that differ from Table 1, and its structure under
    model.structure.BENCH_KEY when it is not eq. (1)'s (every fit below reads it from there).
    ``progress(stage, fraction done)``: called as the work advances (the CLI draws a bar with it).  ``seed``:
    identify's Result of this log with Settings(thrust_law=law, overrides=overrides) when the caller has it
    (batch --diagnose: the estimate it just made), else made here; either way made once, not per search rerun."""
    progress = progress or (lambda stage, done: None)
    p = merge(overrides or {}, source="parameter overrides")
    gated: list = []  # findings refused because they simulate an axis worse on samples they were not fitted on
    progress("fitting the seed model", 0.0)
    seed = seed if seed is not None else search.seed_result(log, overrides, law)
    with np.errstate(all="ignore"):  # a model far off the log overflows its predictions: they score as misfits
        for attempt in range(HELD_OUT_RERUNS + 1):
            exclude = tuple(g["key"] for g in gated)
            found = search.effect_search(log, overrides, law, a_rad_s, progress, exclude, seed)
            d = weigh(found, log, p, law, overrides, exclude)
            # no finding leaves diagnose with a value outside its plausible range, whichever step placed it: it
            # stands in for physics the model lacks, and the search runs again without it
            outside = stand_ins(d.findings)
            if outside and attempt < HELD_OUT_RERUNS:
                gated += outside
                continue
            d = _without_stand_ins(d, outside)
            progress("held-out simulation fits", 0.97)
            h = held_out.held_out_fits(d, log, p, law)
            refuse = held_out.lowering(d.findings, h)
            if not refuse or attempt == HELD_OUT_RERUNS:
                break
            gated += refuse  # the search again without them: a rival they hid may hold on held-out samples
        refused = [{k: v for k, v in g.items() if k != "key"} for g in gated]
        held = [g for g in refused if not g["reason"].startswith(STAND_IN)]
        given = {k: {"value": p[k], "source": "override" if k in (overrides or {}) else "table"} for k in KNOWN}
        refused = d.refused + refused
        return replace(d, held_out=h, refused=refused, settings={**d.settings, "known_values": given,
                                                                  "structure": of_bench(p)},
                       verdict_sentence=d.verdict_sentence + held_out.gate_sentence(held) + held_out.caution(h)
                       + (stand_in_sentence(refused) if d.verdict not in ("explained", "consistent") else ""))


def _without_stand_ins(d: Diagnosis, outside: list[dict]) -> Diagnosis:
    """The diagnosis without the findings ``outside`` names (the reruns did not get rid of them): never reported
    as findings; the verdict can then be at most partly explained (with findings left) or unexplained."""
    if not outside:
        return d
    keys = {g["key"] for g in outside}
    kept = [f for f in d.findings if f"{f.effect}:{f.axis}" not in keys]
    verdict = d.verdict if d.verdict == "consistent" else "partly_explained" if kept else "unexplained"
    return replace(d, findings=kept, verdict=verdict, verdict_sentence=VERDICTS[verdict] + ".",
                   refused=d.refused + [{k: v for k, v in g.items() if k != "key"} for g in outside])


#: diagnose runs its search again without the effects whose model simulated an axis worse on held-out samples
#: than the seed model (held_out.lowering) at most this many times; after that the verdict only cautions
HELD_OUT_RERUNS = 2
