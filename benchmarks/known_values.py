"""Known values off the table and second-order motors (issue #32): blind logs from benches unlike Table 1.

    python benchmarks/known_values.py            # 34 logs on 2 processes (~15 min); writes the "Known values"
                                                 # section of RESULTS.md
    python benchmarks/known_values.py --no-write # print only

Drawn from a seed no test uses (SEED).  Each known value of eq. (1) (known_values.HYPOTHESES) off its Table 1 value
by a factor drawn from 15-50 % either way, on two logs: one from rest with a 12-bit encoder, one cut 20-40 s into
a run with Gaussian noise (0.5-2 mrad); reference, sample rate (100 Hz-1 kHz) and J/B (+-30 % of Table 1) drawn
too, 60 s long.  diagnose is given Table 1.  Right: the off value named first, or as a flagged look-alike of the
first finding, with its refitted value within 30 % of the deviation (|value - true| <= 0.3 |true - table|),
verdict "explained".  Also drawn: clean benches (J/B off Table 1, every known value right): no finding at all;
and second-order motors (a further lag of 0.1-0.4 s on one motor): motor_second_lag named on that axis, first or
as a flagged look-alike, within 30 %, explained.
estimate's adequacy check (identify) and diagnose read the same known-value search; the table shows the value
each names (diagnose's seed check is identify's model_check of the same log, run inside diagnose).
"""
from __future__ import annotations

import math
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

SEED = 20261128  # no test uses it
REFS = ("square", "multisine", "steps", "chirp")
RATES = (100.0, 200.0, 250.0, 500.0, 1000.0)
CLEAN = 4
#: second-order motors: a further lag of 0.1-0.4 s on one motor (from rest and mid-run), Table 1 otherwise
LAGS = 8
VALUE_TOLERANCE = 0.3


def cases() -> list[dict]:
    from trms_ident.known_values import HYPOTHESES

    out = []
    for j, name in enumerate(HYPOTHESES):
        for mid in (False, True):
            out.append(dict(i=len(out), known=name, mid=mid))
    out += [dict(i=len(out) + k, known=None, mid=bool(k % 2)) for k in range(CLEAN)]
    out += [dict(i=len(out) + k, known=None, lag=("pitch", "yaw")[k % 2], mid=k >= LAGS // 2) for k in range(LAGS)]
    return out


def _simulate(c: dict, attempt: int):
    from sim import SimSettings, simulate
    from trms_ident.params import defaults

    rng = np.random.default_rng([SEED, c["i"], attempt])
    table = defaults()
    true = {k: table[k] * rng.uniform(0.7, 1.3) for k in ("J1", "B1", "J2", "B2")}
    factor = 1.0
    if c["known"]:
        factor = 1.0 + rng.choice([-1.0, 1.0]) * rng.uniform(0.15, 0.5)
        true[c["known"]] = table[c["known"]] * factor
    if c["mid"]:
        noise, q, start = float(rng.uniform(5e-4, 2e-3)), 0.0, float(rng.uniform(20, 40))
    else:
        noise, q, start = 0.0, 2 * math.pi / 4096, 0.0
    case = dict(ref=str(rng.choice(REFS)), sample_rate_hz=float(rng.choice(RATES)), duration_s=60.0,
                seed=int(rng.integers(1 << 30)), noise_std_rad=noise, quantization_rad=q, start_s=start,
                overrides=true)
    if c.get("lag"):
        case["effects"] = [{"effect": "motor_second_lag", "axis": c["lag"], "value": float(rng.uniform(0.1, 0.4))}]
    r = simulate(SimSettings(**case))
    ok = np.all(np.isfinite(r.alpha_rad)) and np.max(np.abs(r.alpha_rad)) < 1.4 and np.all(np.isfinite(r.beta_rad))
    return (r, case, factor) if ok else None


def run_case(c: dict) -> dict:
    from trms_ident.diagnosis.run import diagnose
    from trms_ident.errors import IdentificationError, LogFormatError
    from trms_ident.log import validated
    from trms_ident.params import defaults

    for attempt in range(5):  # a drawn bench the PID of eq. (9) cannot hold is drawn again
        got = _simulate(c, attempt)
        if got is not None:
            break
    else:
        return dict(case=c, error="no stable draw")
    r, case, factor = got
    log = validated(r.t_s, r.u1_v, r.u2_v, r.alpha_rad, r.beta_rad, angle_unit="rad")
    t0 = time.perf_counter()
    try:
        d = diagnose(log)
    except (LogFormatError, IdentificationError) as exc:
        return dict(case=c, error=str(exc)[:160])
    seconds = time.perf_counter() - t0
    table = defaults()
    first = d.findings[0] if d.findings else None
    named = None
    if first is not None:
        from trms_ident.diagnosis.compound import SAME

        if first.effect == "known_value":
            named = first.parameter["name"]
        elif f"{first.effect}:{first.axis}" in SAME and f"known_value:{SAME[first.effect + ':' + first.axis]}" in \
                first.alternatives:  # motor_lag is T11/T21 under another name: both name the same value
            named = SAME[f"{first.effect}:{first.axis}"]
        names = [first.parameter["name"] if first.effect == "known_value" else f"{first.effect}:{first.axis}"]
        names += [a.split(":", 1)[1] if a.startswith("known_value:") else a for a in first.alternatives]
    else:
        names = []
    value = None
    for f in d.findings:
        if f.effect == "known_value" and f.parameter["name"] == c["known"]:
            value = f.parameter["value"]
    true = case["overrides"].get(c["known"]) if c["known"] else None
    estimate_named = (d.seed_check.get("suspect") or {}).get("name")
    lag = case.get("effects", [{}])[0].get("value")
    lag_found = next((f.parameter["value"] for f in d.findings if f.effect == "motor_second_lag"
                      and f.axis == c.get("lag")), None)
    return dict(case=c, ref=case["ref"], rate=case["sample_rate_hz"], factor=factor, verdict=d.verdict,
                lag=lag, lag_found=lag_found,
                first=names[0] if names else None, names=names, named=named, value=value, true=true,
                table=table.get(c["known"]) if c["known"] else None, estimate_named=estimate_named,
                findings=len(d.findings), seconds=seconds)


def judge(r: dict) -> bool:
    c = r["case"]
    if "error" in r:
        return False
    if c.get("lag"):
        key = f"motor_second_lag:{c['lag']}"
        return (r["verdict"] == "explained" and key in r["names"] and r["lag_found"] is not None
                and abs(r["lag_found"] - r["lag"]) <= VALUE_TOLERANCE * r["lag"])
    if c["known"] is None:
        return r["findings"] == 0
    if c["known"] not in r["names"] or r["value"] is None or r["verdict"] != "explained":
        return False
    return abs(r["value"] - r["true"]) <= VALUE_TOLERANCE * abs(r["true"] - r["table"])


def main() -> None:
    from results import plain_args

    args = plain_args(__doc__)
    from results import publish

    write = not args.no_write
    t0 = time.perf_counter()
    with ProcessPoolExecutor(max_workers=2) as pool:
        results = list(pool.map(run_case, cases()))
    elapsed = time.perf_counter() - t0
    rows = []
    off = [r for r in results if r["case"]["known"]]
    clean = [r for r in results if not r["case"]["known"] and not r["case"].get("lag")]
    lags = [r for r in results if r["case"].get("lag")]
    for r in results:
        c = r["case"]
        what = (f"{c['known']} x{r.get('factor', 1):.3g}" if c["known"] else
                f"second-order {c['lag']} motor, lag {r['lag']:.3g} s" if c.get("lag") and "lag" in r else
                "clean (J/B off Table 1)")
        cond = ("mid-run, Gaussian" if c["mid"] else "from rest, 12-bit")
        if "error" in r:
            rows.append(f"| {c['i']} | {what} | {cond} | - | refused: {r['error']} | - | - | - | NO |")
            continue
        val = (f"{r['value']:.4g} (true {r['true']:.4g}, table {r['table']:.4g})" if r["value"] is not None else
               (f"- (true {r['true']:.4g})" if c["known"] else
                (f"{r['lag_found']:.4g} s" if r["lag_found"] is not None else "-")))
        same = "yes" if (r["estimate_named"] == r["named"]) else "NO"
        rows.append(f"| {c['i']} | {what} | {cond}, {r['ref']} {r['rate']:g} Hz | {r['verdict']} | "
                    f"{'; '.join(r['names']) or '-'} | {val} | {r['estimate_named'] or '-'} | {same} | "
                    f"{'yes' if judge(r) else 'NO'} |")
    right = sum(judge(r) for r in off)
    false = sum(not judge(r) for r in clean)
    same = sum("error" not in r and r["estimate_named"] == r["named"] for r in results)
    text = ("## Known values (benchmarks/known_values.py, blind, seed 20261128)\n\n"
            "One known value of eq. (1) off Table 1 by 15-50 % either way (J/B off by up to 30 % too), diagnose given "
            "Table 1; two logs per value, from rest with a 12-bit encoder and mid-run with Gaussian noise, 60 s, "
            "100 Hz-1 kHz. Right: the value named first or as a flagged look-alike of the first finding, within 30 % "
            "of the deviation, verdict explained. Clean benches: no finding. 'estimate' is the value estimate's "
            "adequacy check names on the same log.\n\n"
            "| # | bench | log | verdict | first finding; look-alikes | refitted value | estimate names | same | "
            "right |\n|---|---|---|---|---|---|---|---|---|\n" + "\n".join(rows) +
            f"\n\nNamed right: {right}/{len(off)} ({100 * right / max(len(off), 1):.0f} %). Clean benches with a "
            f"finding: {false}/{len(clean)}. Second-order motors (a further lag of 0.1-0.4 s) named on the right "
            f"axis, within 30 %, explained: {sum(judge(r) for r in lags)}/{len(lags)}. "
            f"estimate and diagnose name the same value: {same}/{len(results)}. "
            f"Total {elapsed:.0f} s on 2 processes.\n")
    publish("Known values", text, write)


if __name__ == "__main__":
    main()
