"""What diagnose says on the terminal: the verdict and the findings in plain words on the first line, the figures
below it (issue #47, item 6).  cli.py prints these lines; batch's summary, terminal line and index page name the
findings with the same words (finding_words).  Pure: a Diagnosis (or its diagnosis.json) in, text out."""
from __future__ import annotations

from ..model.effects import with_unit
from ..params import ESTIMATED, marked, not_credible

#: the first line after the verdict, in plain words: {found} is the findings named
HEADLINES = {
    "consistent": "the model fits this log as it is; nothing is missing that this log can show",
    "explained": "the model fits this log to its noise level with {found}",
    "partly_explained": "{found} found, and the model still misses something: with them it does not reach the noise "
                        "level",
    "unexplained": "the model misses something that no effect of the library and no known value explains",
}
#: the first line when J/B refitted with the findings are not credible (diagnosis.verdict.credible): the verdict is
#: then partly explained whether or not the findings reach the noise level, so the line says why instead
LEADS = ("{found} found as leads to check, not measurements: the J/B refitted with them are not credible (the "
         "findings' model is far from this bench)")


def _field(f, name: str):
    return f[name] if isinstance(f, dict) else getattr(f, name)


def finding_words(f) -> str:
    """One finding in plain words: 'a cable on yaw (k = 0.004 N m/rad)', 'Mg = 0.288 N m instead of 0.32 N m'.
    ``f``: a diagnosis.result.Finding or its diagnosis.json entry."""
    from ..model.bench import BenchEffect, is_term, known_keys

    effect, axis, p = _field(f, "effect"), _field(f, "axis"), _field(f, "parameter")
    unit = p.get("unit", "")
    if effect == "known_value":
        return (f"{p['name']} = {with_unit(p['value'], unit)} instead of "
                f"{with_unit(p['table'], unit) if p.get('table') is not None else 'the value given'}")
    key = f"{effect}:{axis}"
    if key in known_keys() or is_term(key):
        return BenchEffect(key, float(p["value"])).phrase()
    return f"{effect} on {axis} ({p['name']} = {with_unit(p['value'], unit)})"


def interval_words(ci95, unit: str, value: float | None = None) -> str:
    """'[0.00398, 0.00402] N m/rad', with as many digits as the ends need to differ (summary.interval_text)."""
    from .summary import interval_text

    return interval_text(ci95[0], ci95[1], value) + ("" if unit == "1" else f" {unit}")


def listed(words: list[str]) -> str:
    """'a', 'a and b', 'a, b and c'."""
    return words[0] if len(words) == 1 else ", ".join(words[:-1]) + " and " + words[-1]


def headline(verdict: str, findings, leads: bool = False) -> str:
    """The verdict's plain words with the findings named (HEADLINES); ``leads``: the J/B refitted with the findings
    are not credible (LEADS)."""
    found = listed([finding_words(f) for f in findings]) if findings else "nothing"
    return (LEADS if leads and findings else HEADLINES[verdict]).format(found=found)


def bench_lines(settings: dict) -> list[str]:
    """What a diagnosis' search stood on beyond eq. (1), one line each (the terminal's and the report's words): the
    bench file's [structure], under which every fit was made, and its input modifications taken as given, from
    which the search started and to which it added; [] under eq. (1) alone."""
    from ..model.bench import BenchEffect
    from ..model.structure import phrases

    lines = []
    if settings.get("structure"):
        lines.append("searched under the bench's structure: " + "; ".join(phrases(settings["structure"])))
    if settings.get("given_effects"):
        lines.append("searched on top of the bench's effects (taken as given, held at their values): " + "; ".join(
            BenchEffect(k, float(v)).phrase() for k, v in settings["given_effects"].items()))
    return lines


def diagnosis_lines(d, source: str) -> list[str]:
    """diagnose's terminal text for Diagnosis ``d`` of the log ``source``: the verdict and findings in plain words,
    then why (the verdict's sentence with its figures), each finding with its value, interval, explanation, one
    fit figure (the 2 s prediction fit of its own step) and its look-alikes, where the evidence is (the report's
    details and diagnosis.json: tests, t statistics and profiles stay off the terminal), the estimates before ->
    after, the held-out fits, what was refused and what lies outside the library."""
    from ..diagnosis.held_out import sentence as held_out_sentence
    from ..diagnosis.predict import fit_change, fit_text

    leads = bool(not_credible(d.augmented))
    lines = [f"{source}: {d.verdict.upper().replace('_', ' ')}: {headline(d.verdict, d.findings, leads)}.",
             f"  why: {d.verdict_sentence}"]
    lines += [f"  {line}" for line in bench_lines(d.settings or {})]
    fits = ", ".join(f"{k} {fit_text(v)}" for k, v in d.fit_before.items())
    if not d.findings:
        lines.append(f"  no effect in the library is found ({d.settings['candidates']} candidates tested; "
                     f"prediction fit {fits})")
    else:
        lines.append(f"  {len(d.findings)} finding(s) (prediction fit before: {fits})")
        for i, f in enumerate(d.findings, 1):
            p, interval = f.parameter, ""
            if p.get("ci95") is not None:
                interval = f", 95 % {interval_words(p['ci95'], p['unit'], p['value'])}"
            if f.effect == "known_value":
                lines.append(f"  {i}. known value {p['name']} ({f.axis}) = {with_unit(p['value'], p['unit'])}, given "
                             f"{with_unit(p['table'], p['unit'])}{interval}")
            else:
                lines.append(f"  {i}. {f.effect} on {f.axis}: {p['name']} = {with_unit(p['value'], p['unit'])}"
                             f"{interval}")
            lines.append(f"     {f.explanation[0].upper() + f.explanation[1:]}.")
            lines.append(f"     with it, the 2 s prediction fit of its axes: {fit_change(f.fit_before, f.fit_after)}")
            if f.alternatives:
                lines.append(f"     this log cannot tell it apart from {listed(list(f.alternatives))}")
        lines.append("  the evidence for each finding (its tests, t statistics, profiles): in report.html (-o) and "
                     "diagnosis.json (-o, --json)")
        lines.append("  estimates  " + "  ".join(f"{k} {marked(k, d.nominal[k])} -> {marked(k, d.augmented[k])}"
                                                 for k in ESTIMATED))
        w = d.with_findings
        if w is not None and w.get("estimates") is not None:
            verdict = {True: "fits", False: "does NOT fit", None: "fit not decided"}[w["adequate"]]
            freed = "".join(f"  {k} {v['estimate']:.6g} {interval_words(v['ci95'], '1', v['estimate'])}"
                            for k, v in (w.get("values") or {}).items())
            lines.append(f"  under the findings' model ({verdict}; `trms-ident export` writes it for --params), "
                         f"95 %: {w['text']}{freed}")
        elif w is not None:
            lines.append(f"  under the findings' model: no estimate ({w['error']})")
    if d.held_out is not None:
        lines.append("  " + held_out_sentence(d.held_out, bool(d.findings)))
    for r in d.refused:
        lines.append(f"  refused: {r['effect']} on {r['axis']}: {r['reason']}")
    for c in d.corrections:
        lines.append(f"  outside the library, {c.axis}: {c.sentence}")
        terms = ", ".join(f"{t['term']} = {with_unit(t['coefficient'], t['unit'])}" for t in c.terms)
        lines.append(f"     data-driven correction (not a named effect): prediction fit "
                     f"{fit_change(c.fit_before, c.fit_after)}; terms {terms}")
        if c.output_error is not None:
            from ..diagnosis.held_out import correction_sentence
            from ..model.bench import shown

            values = ", ".join(f"{shown(k)}: c = {v['estimate']:.4g} {interval_words(v['ci95'], '1', v['estimate'])}"
                               for k, v in c.output_error["values"].items())
            lines.append(f"     {correction_sentence(c, c.output_error)}; {values}")
    return lines
