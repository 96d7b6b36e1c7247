"""What diagnose says on the terminal: the verdict and the findings in plain words on the first line, the figures
below it (issue #47, item 6).  cli.py prints these lines; batch's summary, terminal line and index page name the
findings with the same words (finding_words).  Pure: a Diagnosis (or its diagnosis.json) in, text out."""
from __future__ import annotations

from ..model.effects import with_unit
from ..params import ESTIMATED, marked

#: the first line after the verdict, in plain words: {found} is the findings named
HEADLINES = {
    "consistent": "the model fits this log as it is; nothing is missing that this log can show",
    "explained": "the model fits this log to its noise level with {found}",
    "partly_explained": "{found} found, and the model still misses something: with them it does not reach the noise "
                        "level",
    "unexplained": "the model misses something that no effect of the library and no known value explains",
}


def _field(f, name: str):
    return f[name] if isinstance(f, dict) else getattr(f, name)


def finding_words(f) -> str:
    """One finding in plain words: 'a cable on yaw (k = 0.004 N m/rad)', 'Mg = 0.288 N m instead of 0.32 N m'.
    ``f``: a diagnosis.result.Finding or its diagnosis.json entry."""
    from ..model.bench import BenchEffect, known_keys

    effect, axis, p = _field(f, "effect"), _field(f, "axis"), _field(f, "parameter")
    unit = p.get("unit", "")
    if effect == "known_value":
        return (f"{p['name']} = {with_unit(p['value'], unit)} instead of "
                f"{with_unit(p['table'], unit) if p.get('table') is not None else 'the value given'}")
    key = f"{effect}:{axis}"
    if key in known_keys():
        return BenchEffect(key, float(p["value"])).phrase()
    return f"{effect} on {axis} ({p['name']} = {with_unit(p['value'], unit)})"


def listed(words: list[str]) -> str:
    """'a', 'a and b', 'a, b and c'."""
    return words[0] if len(words) == 1 else ", ".join(words[:-1]) + " and " + words[-1]


def headline(verdict: str, findings) -> str:
    """The verdict's plain words with the findings named (HEADLINES)."""
    found = listed([finding_words(f) for f in findings]) if findings else "nothing"
    return HEADLINES[verdict].format(found=found)


def diagnosis_lines(d, source: str) -> list[str]:
    """diagnose's terminal text for Diagnosis ``d`` of the log ``source``: the verdict and findings in plain words,
    then why (the verdict's sentence with its figures), each finding with its evidence, the estimates before ->
    after, the held-out fits, what was refused and what lies outside the library."""
    from ..diagnosis.held_out import sentence as held_out_sentence
    from ..diagnosis.predict import fit_change, fit_text

    lines = [f"{source}: {d.verdict.upper().replace('_', ' ')}: {headline(d.verdict, d.findings)}.",
             f"  why: {d.verdict_sentence}"]
    fits = ", ".join(f"{k} {fit_text(v)}" for k, v in d.fit_before.items())
    if not d.findings:
        lines.append(f"  no effect in the library is found ({d.settings['candidates']} candidates tested; "
                     f"prediction fit {fits})")
    else:
        lines.append(f"  {len(d.findings)} finding(s) (prediction fit before: {fits})")
        for i, f in enumerate(d.findings, 1):
            if f.effect == "known_value":
                lines.append(f"  {i}. known value {f.parameter['name']} ({f.axis}) = "
                             f"{with_unit(f.parameter['value'], f.parameter['unit'])}, given "
                             f"{with_unit(f.parameter['table'], f.parameter['unit'])}")
            else:
                lines.append(f"  {i}. {f.effect} on {f.axis}: {f.parameter['name']} = "
                             f"{with_unit(f.parameter['value'], f.parameter['unit'])}")
            lines.append(f"     {f.explanation[0].upper() + f.explanation[1:]}.")
            lines.append(f"     fit {fit_change(f.fit_before, f.fit_after)}; {f.evidence}")
        lines.append("  estimates  " + "  ".join(f"{k} {marked(k, d.nominal[k])} -> {marked(k, d.augmented[k])}"
                                                 for k in ESTIMATED))
        w = d.with_findings
        if w is not None and w.get("estimates") is not None:
            verdict = {True: "fits", False: "does NOT fit", None: "fit not decided"}[w["adequate"]]
            lines.append(f"  under the findings' model ({verdict}; `trms-ident export` writes it for --params), "
                         f"95 %: {w['text']}")
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
    return lines
