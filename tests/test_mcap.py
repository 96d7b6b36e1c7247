"""MCAP input: default layouts, mappings, rates, and every bad-input case with message and exit code."""
import json
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from trms_ident.cli import app
from trms_ident.errors import EXIT_BAD_LOG, EXIT_USAGE
from trms_ident.io.cdr import FLOAT64_MULTIARRAY_MSGDEF, JOINT_STATE_MSGDEF
from trms_ident.io.csv_log import write_csv_log
from trms_ident.io.mcap_log import read_mcap_log, write_mcap_log

from .conftest import sim_cached

runner = CliRunner()
THIRD_PARTY = Path(__file__).resolve().parents[2] / "shared" / "third_party" / "mcap"


def _sim():
    return sim_cached("square", 1000.0, 20.0)


@pytest.fixture(scope="module")
def logs(tmp_path_factory):
    d = tmp_path_factory.mktemp("mcap")
    r = _sim()
    cols = (r.t_s, r.u1_v, r.u2_v, r.alpha_rad, r.beta_rad)
    write_csv_log(d / "log.csv", *cols)
    write_mcap_log(d / "log.mcap", *cols, encoding="cdr")
    write_mcap_log(d / "json.mcap", *cols, encoding="json")
    return d


def _estimate(path, out, *extra):
    res = runner.invoke(app, ["estimate", str(path), "-o", str(out), "--no-report", "--json", "-", *extra])
    assert "Traceback" not in res.output
    return res


def test_mcap_and_json_mcap_give_the_csv_estimates(logs, tmp_path):
    ref = json.loads(_estimate(logs / "log.csv", tmp_path / "c").stdout)["estimates"]
    for name in ("log.mcap", "json.mcap"):
        res = _estimate(logs / name, tmp_path / name)
        assert res.exit_code == 0, res.output
        est = json.loads(res.stdout)["estimates"]
        for k in ref:
            assert abs(est[k] / ref[k] - 1) < 1e-9


def _write_ros2(path, topic_msgs, extra_schemas=()):
    """Write messages with mcap-ros2-support's own encoder (an independent implementation)."""
    from mcap_ros2.writer import Writer

    with open(path, "wb") as f:
        w = Writer(f)
        schemas = {}
        for name, text in (("sensor_msgs/msg/JointState", JOINT_STATE_MSGDEF),
                           ("std_msgs/msg/Float64MultiArray", FLOAT64_MULTIARRAY_MSGDEF), *extra_schemas):
            schemas[name] = w.register_msgdef(name, text)
        for topic, schema, t_ns, msg in topic_msgs:
            w.write_message(topic, schemas[schema], msg, log_time=t_ns, publish_time=t_ns)
        w.finish()


def _joint_msg(t_ns, names, values, frame="base_link_long_name"):
    return {"header": {"stamp": {"sec": t_ns // 10**9, "nanosec": t_ns % 10**9}, "frame_id": frame},
            "name": names, "position": values, "velocity": [], "effort": [0.0] * len(names)}


def _voltage_msg(u1, u2, dims=1):
    return {"layout": {"dim": [{"label": "u", "size": 2, "stride": 2}] * dims, "data_offset": 0}, "data": [u1, u2]}


def _bench_messages(n=200, dt_ns=10_000_000, volt_every=1, names=("yaw", "extra", "pitch"), start_ns=5 * 10**9):
    rng = np.random.default_rng(0)
    t = start_ns + np.arange(n) * dt_ns
    a, b = 0.3 * np.sin(np.arange(n) / 20), 0.5 * np.cos(np.arange(n) / 30)
    u = rng.uniform(-2, 2, (n, 2))
    msgs = []
    for i in range(n):
        vals = {"pitch": a[i], "yaw": b[i], "extra": 9.0}
        msgs.append(("/js", "sensor_msgs/msg/JointState", int(t[i]), _joint_msg(int(t[i]), list(names),
                                                                                  [vals[k] for k in names])))
        if i % volt_every == 0:
            msgs.append(("/volt", "std_msgs/msg/Float64MultiArray", int(t[i]), _voltage_msg(*u[i], dims=i % 3)))
    return msgs, t, a, b, u


MAP = ["--signal", "alpha=/js:position[pitch]", "--signal", "beta=/js:position[yaw]",
       "--signal", "u1=/volt:data[0]", "--signal", "u2=/volt:data[1]"]


def test_fast_decoder_matches_reference_encoder_with_other_layouts(tmp_path):
    msgs, t, a, b, u = _bench_messages()
    p = tmp_path / "other.mcap"
    _write_ros2(p, msgs)
    log = read_mcap_log(p, signals=[m for m in MAP if m != "--signal"])
    np.testing.assert_array_equal(log.alpha_rad, a)
    np.testing.assert_array_equal(log.beta_rad, b)
    np.testing.assert_array_equal(log.u1_v, u[:, 0])
    np.testing.assert_allclose(log.t_s, (t - t[0]) * 1e-9, atol=1e-12)
    by_index = read_mcap_log(p, signals=["alpha=/js:position[2]", "beta=/js:position[0]", "u1=/volt:data[0]",
                                         "u2=/volt:data[1]"])
    np.testing.assert_array_equal(by_index.alpha_rad, a)


def test_general_decoder_for_other_message_types(tmp_path):
    msgdef = "std_msgs/Header header\nfloat64 pitch_rad\nfloat64 yaw_rad\n" + JOINT_STATE_MSGDEF.split(
        "================================================================================", 1)[1].join(
        ["================================================================================", ""])
    msgs, t, a, b, u = _bench_messages()
    angles = [("/angles", "trms/msg/Angles", int(ti), {"header": {"stamp": {"sec": int(ti) // 10**9,
                                                                            "nanosec": int(ti) % 10**9},
                                                                  "frame_id": ""}, "pitch_rad": ai, "yaw_rad": bi})
              for ti, ai, bi in zip(t, a, b)]
    volts = [m for m in msgs if m[0] == "/volt"]
    p = tmp_path / "custom.mcap"
    _write_ros2(p, angles + volts, extra_schemas=[("trms/msg/Angles", msgdef)])
    log = read_mcap_log(p, signals=["alpha=/angles:pitch_rad", "beta=/angles:yaw_rad", "u1=/volt:data[0]",
                                    "u2=/volt:data[1]"], time_source="header")
    np.testing.assert_array_equal(log.alpha_rad, a)
    np.testing.assert_array_equal(log.u2_v, u[:, 1])


def test_slower_voltages_are_held_onto_angle_times(tmp_path):
    msgs, t, a, b, u = _bench_messages(volt_every=2)
    p = tmp_path / "rates.mcap"
    _write_ros2(p, msgs)
    log = read_mcap_log(p, signals=[m for m in MAP if m != "--signal"])
    held = u[(np.arange(t.size) // 2) * 2]
    np.testing.assert_array_equal(log.u1_v, held[:, 0])


def _cli_error(path, *extra):
    res = _estimate(path, path.parent / "out", *extra)
    assert res.exit_code != 0
    assert len(res.output.strip().splitlines()) == 1, res.output
    assert not (path.parent / "out").exists()
    return res


def test_gap_in_voltages_is_an_error_not_interpolated(tmp_path):
    msgs, t, a, b, u = _bench_messages()
    drop = {int(t[i]) for i in range(100, 110)}
    msgs = [m for m in msgs if not (m[0] == "/volt" and m[2] in drop)]
    p = tmp_path / "gap.mcap"
    _write_ros2(p, msgs)
    res = _cli_error(p, *MAP)
    assert res.exit_code == EXIT_BAD_LOG
    # one or two missing messages are tolerated (held for up to 3 periods); the fourth sample is stale
    assert "/js message 103 (t = 1.03 s): u1 from /volt is stale: its last message is 0.04 s old " \
           "(its period is 0.01 s); a gap in /volt is not interpolated over" in res.output


@pytest.mark.parametrize("case, message", [
    ("text", "not an MCAP file (the magic bytes are missing)"),
    ("empty", "file is empty; expected an MCAP recording"),
    ("missing_topic", "no topic /trms/voltage (needed for u1, u2); topics: /trms/joint_states"),
    ("missing_joint", "topic /js: message 0 has no joint of that name (position[pitch], position[roll])"),
    ("crc", "the file is corrupt"),
])
def test_bad_mcap(tmp_path, logs, case, message):
    p = tmp_path / f"{case}.mcap"
    extra = []
    if case == "text":
        p.write_text("t,u1,u2,alpha,beta\n")
    elif case == "empty":
        p.write_bytes(b"")
    elif case == "missing_topic":
        msgs, *_ = _bench_messages()
        _write_ros2(p, [("/trms/joint_states",) + m[1:] for m in msgs if m[0] == "/js"])
    elif case == "missing_joint":
        msgs, *_ = _bench_messages()
        _write_ros2(p, msgs)
        extra = ["--signal", "alpha=/js:position[pitch]", "--signal", "beta=/js:position[roll]",
                 "--signal", "u1=/volt:data[0]", "--signal", "u2=/volt:data[1]"]
    elif case == "crc":
        data = bytearray((logs / "log.mcap").read_bytes())
        data[len(data) // 3] ^= 0xFF  # inside a compressed chunk
        p.write_bytes(bytes(data))
    res = _cli_error(p, *extra)
    assert res.exit_code == EXIT_BAD_LOG, res.output
    assert message in res.output, res.output
    assert res.output.startswith(f"error: {p}: ")


def test_truncated_mcap_recovers_what_is_readable(tmp_path, logs):
    data = (logs / "log.mcap").read_bytes()
    p = tmp_path / "cut.mcap"
    p.write_bytes(data[: int(len(data) * 0.6)])
    res = _estimate(p, tmp_path / "o")
    assert res.exit_code == 0, res.output
    assert "warning: the file ends early near byte" in res.stderr and "truncated" in res.stderr
    doc = json.loads(res.stdout)
    assert 0 < doc["input"]["samples"] < 20001
    assert "truncated" in doc["input"]["warnings"]


def test_unknown_encoding_and_bad_signal_option(tmp_path, logs):
    p = THIRD_PARTY / "wrong_rmw_test_0.mcap"
    if not p.exists():
        pytest.skip("shared/third_party/mcap is not beside the repository")
    res = _estimate(p, tmp_path / "o", "--signal", "alpha=/test_topic:float64_value")
    assert res.exit_code == EXIT_BAD_LOG
    assert "topic /test_topic: message encoding 'wrong_format' is not one this tool reads; expected cdr or json" \
        in res.output
    res = _estimate(logs / "log.mcap", tmp_path / "o", "--signal", "theta=/a:b")
    assert res.exit_code == EXIT_USAGE and "signal must be one of alpha, beta, u1, u2" in res.output
    res = _estimate(logs / "log.csv", tmp_path / "o", "--signal", "alpha=/a:b")
    assert res.exit_code == EXIT_BAD_LOG and "line 1: no column '/a:b' (for alpha); columns: t,u1,u2" in \
        res.output.replace(", ", ",")


@pytest.mark.parametrize("name", ["talker.mcap", "cdr_test_0.mcap", "only_topics.mcap"])
def test_inspect_reads_files_from_other_writers(name):
    p = THIRD_PARTY / name
    if not p.exists():
        pytest.skip("shared/third_party/mcap is not beside the repository")
    res = runner.invoke(app, ["inspect", str(p), "--json", "-"])
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout)
    assert doc["topics"] and all("message_encoding" in t for t in doc["topics"])
    if name == "cdr_test_0.mcap":
        arrays = next(t for t in doc["topics"] if t["topic"] == "/array_topic")
        assert arrays["messages"] == 4 and "float64_values[0..2]" in arrays["numeric_fields"]


def test_inspect_refuses_unknown_encoding_and_suggests_mapping(logs):
    p = THIRD_PARTY / "wrong_rmw_test_0.mcap"
    if p.exists():
        res = runner.invoke(app, ["inspect", str(p)])
        assert res.exit_code == EXIT_BAD_LOG and "message encoding 'wrong_format'" in res.output
    res = runner.invoke(app, ["inspect", str(logs / "log.mcap"), "--json", "-"])
    doc = json.loads(res.stdout)
    assert doc["suggested_signals"]["alpha"] == "alpha=/trms/joint_states:position[pitch]"
    assert doc["topics"][0]["rate_hz"] == pytest.approx(1000.0)


def test_missing_mcap_file_is_an_input_error(tmp_path):
    from trms_ident.errors import InputNotFoundError

    with pytest.raises(InputNotFoundError, match="no such file"):
        read_mcap_log(tmp_path / "x.mcap")


@pytest.mark.parametrize("chunking", ["none", "small"])
def test_unchunked_and_many_small_chunks_read_alike(logs, tmp_path, chunking):
    """The chunk pipeline (worker threads, records grouped by channel, channels met inside chunks) gives the
    same log as the reference layout, for unchunked files and for chunks holding a few messages each."""
    from mcap.writer import Writer

    from trms_ident.io.cdr import float64_multiarray_encoder, joint_state_encoder

    ref = read_mcap_log(logs / "log.mcap")
    n = 3000
    t_ns = np.round(ref.t_s[:n] * 1e9).astype(np.int64) + 10**9
    p = tmp_path / f"{chunking}.mcap"
    with open(p, "wb") as f:
        w = Writer(f, use_chunking=chunking != "none", chunk_size=700)
        w.start(profile="ros2", library="test")
        sj = w.register_schema("sensor_msgs/msg/JointState", "ros2msg", JOINT_STATE_MSGDEF.encode())
        sv = w.register_schema("std_msgs/msg/Float64MultiArray", "ros2msg", FLOAT64_MULTIARRAY_MSGDEF.encode())
        cj = w.register_channel("/trms/joint_states", "cdr", sj)
        ej, ev = joint_state_encoder(["pitch", "yaw"]), float64_multiarray_encoder(2)
        cv = None
        for i in range(n):
            tn = int(t_ns[i])
            if cv is None and i == 5:  # a channel that first appears after some chunks
                cv = w.register_channel("/trms/voltage", "cdr", sv)
            if cv is not None:
                w.add_message(cv, tn, ev((ref.u1_v[i], ref.u2_v[i])), tn, i)
            w.add_message(cj, tn, ej(tn, (ref.alpha_rad[i], ref.beta_rad[i])), tn, i)
        w.finish()
    log = read_mcap_log(p)
    np.testing.assert_array_equal(log.alpha_rad, ref.alpha_rad[5:n])
    np.testing.assert_array_equal(log.u2_v, ref.u2_v[5:n])
    np.testing.assert_allclose(log.t_s, ref.t_s[5:n] - ref.t_s[5], atol=1e-9)
    assert "dropped the first 5 angle samples" in log.meta["warnings"]
