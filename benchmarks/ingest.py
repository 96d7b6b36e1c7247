"""MCAP ingestion benchmark (issue #4): messages per second reading the default ROS 2 layout.

    python benchmarks/ingest.py            # 10 min at 1 kHz = 1.2 M messages

Compares read_mcap_log (compiled chunk scan + bulk CDR decoding) with the mcap library's
plain record iteration and with mcap-ros2-support's decoder (both on the first 100 000
messages, extrapolated as a rate).  Median of 3 warm runs.
"""
from __future__ import annotations

import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from sim import SimSettings, simulate  # noqa: E402
from trms_ident.io.mcap_log import read_mcap_log, write_mcap_log  # noqa: E402


def rate_of(fn, n_msgs) -> float:
    fn()
    times = []
    for _ in range(3):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return n_msgs / statistics.median(times)


def main():
    from results import plain_args

    args = plain_args(__doc__)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "ten_minutes.mcap"
        r = simulate(SimSettings(ref="multisine", duration_s=600.0, quantization_rad=2 * np.pi / 4096))
        write_mcap_log(path, r.t_s, r.u1_v, r.u2_v, r.alpha_rad, r.beta_rad)
        n = 2 * r.t_s.size
        ours = rate_of(lambda: read_mcap_log(path), n)
        json_path = Path(tmp) / "ten_minutes_json.mcap"
        write_mcap_log(json_path, r.t_s, r.u1_v, r.u2_v, r.alpha_rad, r.beta_rad, encoding="json")
        ours_json = rate_of(lambda: read_mcap_log(json_path), n)

        from mcap.reader import make_reader
        from mcap_ros2.decoder import DecoderFactory

        sub = 100_000

        def plain():
            with open(path, "rb") as f:
                for i, _ in enumerate(make_reader(f).iter_messages()):
                    if i + 1 >= sub:
                        break

        def ros2():
            with open(path, "rb") as f:
                for i, _ in enumerate(make_reader(f, decoder_factories=[DecoderFactory()]).iter_decoded_messages()):
                    if i + 1 >= sub:
                        break

        plain_rate = rate_of(plain, sub)
        ros2_rate = rate_of(ros2, sub)
        mb = path.stat().st_size / 1e6
    text = (f"## MCAP ingestion (benchmarks/ingest.py, median of 3 warm runs)\n\n"
            f"| reader | messages/s |\n|---|---|\n"
            f"| trms-ident read_mcap_log, ROS 2 CDR (whole log: {n:,} messages, {mb:.0f} MB, zstd) | {ours:,.0f} |\n"
            f"| trms-ident read_mcap_log, JSON layout (same log) | {ours_json:,.0f} |\n"
            f"| mcap iter_messages, records only (first {sub:,}) | {plain_rate:,.0f} |\n"
            f"| mcap-ros2-support decoder (first {sub:,}) | {ros2_rate:,.0f} |\n\n"
            f"Target: 250 000 messages/s or more for the ROS 2 CDR and JSON layouts.\n")
    from results import update_section
    if not args.no_write:
        update_section(Path(__file__).with_name("RESULTS.md"), "MCAP ingestion", text)
    print(text)


if __name__ == "__main__":
    main()
