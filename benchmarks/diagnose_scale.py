"""Diagnose at scale (issue #12, point 5): `trms-ident diagnose` on 10 min, 1 h and 4 h of 1 kHz data.

    python benchmarks/diagnose_scale.py            # 10 min, 1 h, 1 h with a cable, 4 h: about 16 minutes
    python benchmarks/diagnose_scale.py --only 1h-cable --repeat 3

Each figure is a fresh process timed from outside (start-up included); peak memory is its max RSS
(os.wait4), the logs made in a child process (see ratios.py).  The yardstick is the plain scipy pipeline on
the same CSV: pandas.read_csv plus 16 scipy.signal.lfilter passes (benchmarks/ratios.py), run right after the
diagnose, once each; with ``--repeat N``, N alternating pairs (diagnose, yardstick) and the medians (the
yardstick alone moved by 25 % between two logs of the same size in one run).
Targets (issue #32): the clean hour and the hour with one effect present (a yaw cable of 0.004 N m/rad, so the
search finds, refits and checks a finding) each within 1.5 GB and at most 25x the yardstick; 4 h within 4 GB.  Writes the "Diagnose at
scale" section of RESULTS.md.
"""
from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

import numpy as np  # noqa: E402
from ratios import PY, SCIPY_PIPELINE, make_logs, timed  # noqa: E402

LENGTHS_S = {"10min": 600.0, "1h": 3600.0, "1h-cable": 3600.0, "4h": 14400.0}
CABLE_YAW = {"1h-cable": 0.004}  # N m/rad
TARGETS = {"1h": (1500.0, 25.0), "1h-cable": (1500.0, 25.0), "4h": (4000.0, None)}


def _found(path: Path) -> str:
    """'verdict: effect:axis=value, ...' from diagnose's JSON."""
    import json
    d = json.loads(path.read_text())
    named = []
    for f in d.get("findings", []):
        value = (f.get("parameter") or {}).get("value")
        named.append(f"{f.get('effect')}:{f.get('axis')}={value:.3g}" if isinstance(value, float) else
                     f"{f.get('effect')}:{f.get('axis')}")
    return f"{d.get('verdict')}: {', '.join(named) or 'none'}"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--only", choices=list(LENGTHS_S))
    ap.add_argument("--repeat", type=int, default=1, help="alternating (diagnose, yardstick) pairs per log")
    ap.add_argument("--out", default=str(Path(__file__).with_name("RESULTS.md")))
    args = ap.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name, seconds in LENGTHS_S.items():
            if args.only and name != args.only:
                continue
            path = Path(tmp) / f"{name}.csv"
            # in a child: this process stays small (see ratios.py)
            make_logs(path, seconds, cable_yaw=CABLE_YAW.get(name, 0.0))
            out = Path(tmp) / "d.json"
            runs = []
            for _ in range(max(args.repeat, 1)):
                wall, peak = timed([PY, "-m", "trms_ident", "diagnose", str(path), "--json", str(out)])
                base, _ = timed([PY, "-c", SCIPY_PIPELINE, str(path)])
                runs.append((wall, peak, base))
            wall, peak, base = (float(np.median([r[i] for r in runs])) for i in range(3))
            rows.append((name, wall, peak, base, _found(out)))
            print(rows[-1], file=sys.stderr)
            path.unlink()
    lines = ["| log | diagnose [s] | peak memory [MB] | scipy pipeline [s] | diagnose / pipeline | verdict: findings "
             "| targets |", "|---|---|---|---|---|---|---|"]
    for name, wall, peak, base, found in rows:
        mem_t, ratio_t = TARGETS.get(name, (None, None))
        target = []
        if mem_t:
            target.append(f"<= {mem_t:.0f} MB: {'met' if peak <= mem_t else 'not met'}")
        if ratio_t:
            target.append(f"<= {ratio_t:g}x: {'met' if wall / base <= ratio_t else 'not met'}")
        lines.append(f"| {name} | {wall:.1f} | {peak:.0f} | {base:.2f} | {wall / base:.1f} | {found} "
                     f"| {'; '.join(target) or '-'} |")
    runs = "one run each" if args.repeat <= 1 else f"medians of {args.repeat} alternating pairs"
    text = (f"## Diagnose at scale (benchmarks/diagnose_scale.py, fresh processes, {runs}, this 2-core "
            "machine)\n\n" + "\n".join(lines) + "\n\nLogs: multisine, 12-bit encoder, 1 kHz; 10min, 1h and 4h "
            "clean (the seed model fits: every candidate is tested and none passes, the full search), 1h-cable the "
            "same bench with a yaw cable of 0.004 N m/rad.\n")
    from results import update_section
    update_section(Path(args.out), "Diagnose at scale", text)
    print(text)


if __name__ == "__main__":
    main()
