"""`tendyn log import` of ROS bags (issue 31, item 1): ROS 2 bags (sqlite3 and MCAP storage) and ROS 1 bags,
written here by the rosbags library's own writers; JointState by joint name, any message by field path, header
stamps or receive times, several topics on one time base with what was done said; bag → log → identify equals
the equivalent CSV to 1e-12; bad bags and maps refused in one line."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("rosbags")
from rosbags.rosbag1 import Writer as Writer1  # noqa: E402
from rosbags.rosbag2 import StoragePlugin, Writer as Writer2  # noqa: E402
from rosbags.typesys import Stores, get_typestore  # noqa: E402

from tendyn.cli import main  # noqa: E402
from tendyn.io import read_log  # noqa: E402
from tendyn.io.importer import import_logs  # noqa: E402
from tendyn.io.logs import LogError  # noqa: E402

KINDS = ["sqlite3", "mcap", "ros1"]
JS = "sensor_msgs/msg/JointState"


class Bag:
    """Messages written by rosbags' own writer into a ROS 2 bag folder (sqlite3 or MCAP) or a ROS 1 .bag."""

    def __init__(self, kind):
        self.kind = kind
        self.store = get_typestore(Stores.ROS1_NOETIC if kind == "ros1" else Stores.ROS2_HUMBLE)
        self.topics: dict[str, tuple[str, list]] = {}

    def header(self, stamp_ns, seq=0):
        T = self.store.types["builtin_interfaces/msg/Time"]
        H = self.store.types["std_msgs/msg/Header"]
        stamp = T(sec=stamp_ns // 10**9, nanosec=stamp_ns % 10**9)
        return H(seq=seq, stamp=stamp, frame_id="") if self.kind == "ros1" else H(stamp=stamp, frame_id="")

    def joint_state(self, stamp_ns, names, position=(), velocity=(), effort=()):
        return self.store.types[JS](header=self.header(stamp_ns), name=list(names),
                                    position=np.asarray(position, float), velocity=np.asarray(velocity, float),
                                    effort=np.asarray(effort, float))

    def wrench(self, stamp_ns, fx):
        ty = self.store.types
        V = ty["geometry_msgs/msg/Vector3"]
        w = ty["geometry_msgs/msg/Wrench"](force=V(x=fx, y=0.0, z=0.0), torque=V(x=0.0, y=0.0, z=0.0))
        return ty["geometry_msgs/msg/WrenchStamped"](header=self.header(stamp_ns), wrench=w)

    def array(self, values):
        ty = self.store.types
        layout = ty["std_msgs/msg/MultiArrayLayout"](dim=[], data_offset=0)
        return ty["std_msgs/msg/Float64MultiArray"](layout=layout, data=np.asarray(values, float))

    def add(self, topic, recv_ns, msg):
        self.topics.setdefault(topic, (msg.__msgtype__, []))[1].append((recv_ns, msg))

    def write(self, path: Path) -> Path:
        if self.kind == "ros1":
            path = path.with_suffix(".bag")
            w = Writer1(path)
            ser = self.store.serialize_ros1
        else:
            w = Writer2(path, version=9,
                        storage_plugin=StoragePlugin.MCAP if self.kind == "mcap" else StoragePlugin.SQLITE3)
            ser = self.store.serialize_cdr
        with w:
            conns = {t: w.add_connection(t, ty, typestore=self.store) for t, (ty, _) in self.topics.items()}
            allmsgs = sorted((r, t, m) for t, (_, ms) in self.topics.items() for r, m in ms)
            for recv, t, m in ((r, t, m) for r, t, m in allmsgs):
                w.write(conns[t], recv, ser(m, self.topics[t][0]))
        return path


def write_map(path, body, log_extra=""):
    path.write_text(f'schema = 1\n[log]\ndevice = "axis_gen"\nexperiment = "exciting"\n{log_extra}\n' + body)
    return path


def sig(topic, field, signal, joint=None, extra=""):
    j = f'joint = "{joint}"\n' if joint else ""
    return f'[[signals]]\ntopic = "{topic}"\nfield = "{field}"\n{j}signal = "{signal}"\n{extra}\n'


T0 = 1_700_000_000 * 10**9          # header stamps in epoch ns, as a robot's clock gives them


@pytest.mark.parametrize("kind", KINDS)
def test_joint_states_by_joint_name_in_every_bag_format(tmp_path, kind):
    """Joints are found by name even when a message lists them in another order; time 0 is the first stamp."""
    n, rate = 50, 1000.0
    rng = np.random.default_rng(1)
    q = rng.standard_normal((n, 2))
    tau = rng.standard_normal((n, 2))
    bag = Bag(kind)
    for k in range(n):
        st = T0 + k * 10**6
        order = [0, 1] if k % 2 else [1, 0]                 # every other message lists b before a
        bag.add("/joint_states", st + 250_000, bag.joint_state(st, [["a", "b"][i] for i in order],
                                                              position=q[k, order], effort=tau[k, order]))
    f = bag.write(tmp_path / "run")
    mp = write_map(tmp_path / "map.toml", sig("/joint_states", "position", "q_motor_1", "a")
                   + sig("/joint_states", "position", "q_motor_2", "b")
                   + sig("/joint_states", "effort", "torque_motor_2", "b", "scale = 0.5"))
    log = import_logs([f], mp)
    np.testing.assert_array_equal(log.time, np.arange(n) / rate)
    np.testing.assert_array_equal(log["q_motor_1"], q[:, 0])
    np.testing.assert_array_equal(log["q_motor_2"], q[:, 1])
    np.testing.assert_array_equal(log["torque_motor_2"], 0.5 * tau[:, 1])
    assert log.meta["rate_hz"] == pytest.approx(rate)
    assert any("merged without resampling" in s for s in log.meta["options"]["import_notes"])
    # receive time: the same samples, 0.25 ms later each, so the same time column from 0
    mp2 = write_map(tmp_path / "map2.toml", sig("/joint_states", "position", "q_motor_1", "a"),
                    'time_source = "receive"')
    np.testing.assert_array_equal(import_logs([f], mp2).time, np.arange(n) / rate)


@pytest.mark.parametrize("kind", ["mcap", "sqlite3"])
def test_bare_storage_files_and_bag_folders_through_the_cli(tmp_path, capsys, kind):
    bag = Bag(kind)
    for k in range(20):
        bag.add("/js", T0 + k * 10**6, bag.joint_state(T0 + k * 10**6, ["a"], position=[0.1 * k]))
    folder = bag.write(tmp_path / "run")
    storage = next(folder.glob("*.mcap" if kind == "mcap" else "*.db3"))
    mp = write_map(tmp_path / "map.toml", sig("/js", "position", "q_motor_1", "a"))
    for src in (folder, storage):
        out = tmp_path / f"{src.name}.csv"
        assert main(["log", "import", str(src), "--map", str(mp), "--out", str(out), "--json"]) == 0
        doc = json.loads(capsys.readouterr().out)
        assert doc["n_samples"] == 20 and doc["notes"]
        np.testing.assert_allclose(read_log(out)["q_motor_1"], 0.1 * np.arange(20), rtol=0, atol=0)


@pytest.mark.parametrize("kind", KINDS)
def test_several_topics_are_resampled_onto_one_time_base_and_said(tmp_path, kind):
    """JointState at 1 kHz, a WrenchStamped at 400 Hz starting later, both linear in time: linear interpolation
    onto 500 Hz over the overlap is then exact (the oracle is the line, not the importer's interpolation)."""
    bag = Bag(kind)
    for k in range(300):                                             # 0 … 0.299 s
        st = T0 + k * 10**6
        bag.add("/joint_states", st, bag.joint_state(st, ["a"], position=[2.0 * k * 1e-3]))
    for k in range(100):                                             # 0.0125 s … 0.26 s
        st = T0 + 12_500_000 + k * 2_500_000
        bag.add("/wrench", st, bag.wrench(st, 3.0 + 5.0 * (st - T0) * 1e-9))
    f = bag.write(tmp_path / "run")
    body = (sig("/joint_states", "position", "q_motor_1", "a")
            + sig("/wrench", "wrench.force.x", "torque_joint_ext_1"))
    with pytest.raises(LogError, match="log.rate_hz: required: the signals have different stamps"):
        import_logs([f], write_map(tmp_path / "m.toml", body))
    log = import_logs([f], write_map(tmp_path / "m.toml", body, "rate_hz = 500.0"))
    t_abs = 0.0125 + log.time                                          # the overlap starts at the wrench's first stamp
    assert log.time[-1] == pytest.approx(0.246) and log.meta["rate_hz"] == 500.0   # the last 2 ms step ≤ 0.2475 s
    np.testing.assert_allclose(log["q_motor_1"], 2.0 * t_abs, rtol=0, atol=1e-12)
    np.testing.assert_allclose(log["torque_joint_ext_1"], 3.0 + 5.0 * t_abs, rtol=0, atol=1e-12)
    notes = " ".join(log.meta["options"]["import_notes"])
    assert "resampled onto 500 Hz by linear interpolation" in notes and "outside the overlap, dropped" in notes


@pytest.mark.parametrize("kind", KINDS)
def test_duplicated_stale_stamps_and_missing_joints_are_dropped_and_said(tmp_path, kind):
    bag = Bag(kind)
    stamps = [0, 1, 2, 2, 3, 1, 4, 5, 6, 7]                # ms: one duplicate (2), one stale (1 after 3)
    for k, ms in enumerate(stamps):
        st = T0 + ms * 10**6
        names = ["a"] if k == 7 else ["a", "b"]            # the message at 5 ms lacks joint b
        bag.add("/js", T0 + k * 10**6, bag.joint_state(st, names, position=[10.0 * k, 20.0 * k][:len(names)]))
    f = bag.write(tmp_path / "run")
    body = sig("/js", "position", "q_motor_1", "a") + sig("/js", "position", "q_motor_2", "b")
    one = import_logs([f], write_map(tmp_path / "m1.toml", sig("/js", "position", "q_motor_1", "a")))
    np.testing.assert_array_equal(one.time, np.arange(8) * 1e-3)
    np.testing.assert_array_equal(one["q_motor_1"], 10.0 * np.array([0, 1, 2, 4, 6, 7, 8, 9]))
    notes = " ".join(one.meta["options"]["import_notes"])
    assert "1 message(s) with a duplicated header stamp dropped" in notes and "1 stale message(s) dropped" in notes
    with pytest.raises(LogError, match="different stamps"):             # b has no sample at 5 ms
        import_logs([f], write_map(tmp_path / "m2.toml", body))
    log = import_logs([f], write_map(tmp_path / "m3.toml", body, "rate_hz = 1000.0"))
    assert "joint 'b' position missing from 1 of 8 messages" in " ".join(log.meta["options"]["import_notes"])
    np.testing.assert_allclose(log["q_motor_2"][5], 0.5 * (20.0 * 6 + 20.0 * 8))   # interpolated over the gap


def test_any_message_by_field_path_with_receive_time(tmp_path):
    bag = Bag("mcap")
    for k in range(10):
        bag.add("/cmd", T0 + k * 2 * 10**6, bag.array([k, 2.0 * k, 3.0 * k]))
    f = bag.write(tmp_path / "run")
    mp = write_map(tmp_path / "m.toml", sig("/cmd", "data[2]", "torque_motor_cmd_1"), 'time_source = "receive"')
    log = import_logs([f], mp)
    np.testing.assert_array_equal(log["torque_motor_cmd_1"], 3.0 * np.arange(10))
    assert log.meta["rate_hz"] == pytest.approx(500.0)
    with pytest.raises(LogError, match="has no header.stamp: set log.time_source"):
        import_logs([f], write_map(tmp_path / "m2.toml", sig("/cmd", "data[2]", "torque_motor_cmd_1")))


def _one_topic_bag(tmp_path, kind="mcap"):
    bag = Bag(kind)
    for k in range(10):
        bag.add("/js", T0 + k * 10**6, bag.joint_state(T0 + k * 10**6, ["a"], position=[k], effort=[k]))
    return bag.write(tmp_path / "run")


@pytest.mark.parametrize("body, log_extra, message", [
    (sig("/nope", "position", "q_motor_1", "a"), "", "signals[1].topic: no topic '/nope' in run (topics: /js)"),
    (sig("/js", "positon", "q_motor_1", "a"), "", "signals[1].field: 'positon': no field 'positon' in "
                                                  "sensor_msgs/msg/JointState (fields: header, name, position"),
    (sig("/js", "position", "q_motor_1", "z"), "", "signals[1].joint: joint 'z' position is in no message of /js"),
    (sig("/js", "header", "q_motor_1"), "", "signals[1].field: 'header' is a std_msgs/msg/Header"),
    (sig("/js", "position", "q_motor_1"), "", "'position' is an array of 1, not a number (add [k])"),
    (sig("/js", "position[0]", "q_motor_1", extra="index = 1"), "", "signals[1].index: only for a column"),
    ('[[signals]]\ntopic = "/js"\nsignal = "q_motor_1"\n', "", "signals[1].field: missing required key"),
    (sig("/js", "position", "time", "a"), "", "signals[1].signal: time of a bag comes from log.time_source"),
    (sig("/js", "position", "q_motor_1", "a"), 'time_source = "arrival"', "log.time_source: must be one of header"),
    (sig("/js", "position", "q_motor_1", "a"), "rate_hz = 10.0", "log.rate_hz: 10 Hz, but the stamps are"),
    (sig("/js", "pos..x", "q_motor_1"), "", "signals[1].field: 'pos..x' is not a field path"),
    ('[[signals]]\ncolumn = "x"\nsignal = "q_motor_1"\n', "rate_hz = 1.0", "signals[1]: run is a ROS bag: give topic and field"),
])
def test_bad_maps_are_refused_in_one_line(tmp_path, capsys, body, log_extra, message):
    f = _one_topic_bag(tmp_path)
    mp = write_map(tmp_path / "m.toml", body, log_extra)
    with pytest.raises(LogError) as exc:
        import_logs([f], mp)
    assert message in str(exc.value), str(exc.value)
    assert main(["log", "import", str(f), "--map", str(mp), "--out", str(tmp_path / "o.csv")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("tendyn: error:") and "\n" not in err and "Traceback" not in err


@pytest.mark.parametrize("name, content", [
    ("run.bag", b"#ROSBAG V2.0\n" + b"\x00\x01garbage" * 20),
    ("run.mcap", b"\x89MCAP0\r\n" + b"garbage" * 20),
    ("run.db3", b"SQLite format 3\x00" + b"garbage" * 20),
    ("run.bag", b""),
])
def test_broken_bags_are_refused_in_one_line(tmp_path, capsys, name, content):
    f = tmp_path / name
    f.write_bytes(content)
    mp = write_map(tmp_path / "m.toml", sig("/js", "position", "q_motor_1", "a"))
    assert main(["log", "import", str(f), "--map", str(mp), "--out", str(tmp_path / "o.csv")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"tendyn: error: {name}: not a readable ROS bag") and "\n" not in err, err


def test_a_folder_that_is_not_a_bag_is_refused(tmp_path, capsys):
    (tmp_path / "notabag").mkdir()
    mp = write_map(tmp_path / "m.toml", sig("/js", "position", "q_motor_1", "a"))
    assert main(["log", "import", str(tmp_path / "notabag"), "--map", str(mp), "--out", str(tmp_path / "o.csv")]) == 2
    assert "not a ROS 2 bag (no metadata.yaml in it)" in capsys.readouterr().err


# -- round trip: bag → log → identify gives the same parameters as the equivalent CSV ------------------------

def _axis_motion(rate, seconds):
    """Position [m], force [N] of a linear axis (the prismatic axis of test_ident_real_logs): 3.1 kg, viscous
    12 N·s/m, Coulomb 3 N, offset 1.5 N."""
    t = np.arange(int(seconds * rate)) / rate
    x = np.zeros_like(t); v = np.zeros_like(t); a = np.zeros_like(t)
    for k, (amp, f) in enumerate(((0.12, 0.4), (0.04, 1.1), (0.015, 2.3))):
        w = 2 * np.pi * f
        x += amp * np.sin(w * t + k); v += amp * w * np.cos(w * t + k); a -= amp * w * w * np.sin(w * t + k)
    return t, x, 3.1 * a + 12.0 * v + 3.0 * np.tanh(v / 1e-4) + 1.5


@pytest.mark.parametrize("kind", KINDS)
def test_bag_to_log_to_identify_equals_the_csv_route(tmp_path, capsys, kind):
    from test_ident_real_logs import AXIS

    rate = 500.0
    t, x, force = _axis_motion(rate, 12.0)
    dev = tmp_path / "axis_gen.toml"
    dev.write_text(AXIS)
    csv = tmp_path / "axis.csv"
    csv.write_text("t,x,force\n" + "".join(f"{a!r},{b!r},{c!r}\n" for a, b, c in zip(t.tolist(), x.tolist(), force.tolist())))
    cmap = tmp_path / "csv.toml"
    cmap.write_text('schema = 1\n[log]\ndevice = "axis_gen"\nexperiment = "exciting"\n'
                    '[[signals]]\ncolumn = "t"\nsignal = "time"\n'
                    '[[signals]]\ncolumn = "x"\nsignal = "q_motor_1"\nunit = "m"\n'
                    '[[signals]]\ncolumn = "force"\nsignal = "torque_motor_1"\nunit = "N"\n')
    bag = Bag(kind)
    for k in range(t.size):
        st = T0 + k * 2_000_000                               # 500 Hz in integer ns
        bag.add("/joint_states", st + 100_000, bag.joint_state(st, ["x"], position=[x[k]], effort=[force[k]]))
    f = bag.write(tmp_path / "run")
    bmap = write_map(tmp_path / "bag.toml", sig("/joint_states", "position", "q_motor_1", "x", 'unit = "m"')
                     + sig("/joint_states", "effort", "torque_motor_1", "x", 'unit = "N"'))
    params = {}
    for name, raw, mp in (("csv", csv, cmap), ("bag", f, bmap)):
        out = tmp_path / f"{name}.parquet"
        assert main(["log", "import", str(raw), "--map", str(mp), "--out", str(out)]) == 0
        assert main(["identify", str(dev), str(out), "--json", "--quiet"]) == 0
        doc = json.loads(capsys.readouterr().out)
        params[name] = {p["name"]: p["value"] for p in doc["params"]}
    assert params["bag"].keys() == params["csv"].keys()
    for k, v in params["csv"].items():
        assert params["bag"][k] == pytest.approx(v, rel=1e-12, abs=1e-12), k
    assert params["bag"]["FV1"] == pytest.approx(12.0, rel=0.02)
