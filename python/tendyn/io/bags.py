"""Signals of ROS bags, read through the ``rosbags`` library (no ROS install): ROS 2 bags (a bag folder with its
``metadata.yaml``, or a bare ``.db3`` (sqlite3) or ``.mcap`` storage file) and ROS 1 ``.bag`` files.

The import map (``tendyn.io.importer``) names, per log signal, the ``topic``, the message ``field`` and, for a
message with a ``name`` array (``sensor_msgs/JointState``), the ``joint``:

* ``field = "position"``, ``joint = "j2"``: the element of ``position`` at the index of ``"j2"`` in ``name``
  (``velocity``, ``effort`` alike); messages that lack the joint, or whose array is shorter, miss that sample;
* ``field = "wrench.force.x"`` or ``"data[2]"``: any message by field path (attributes with dots, array elements
  with a 0-based ``[k]`` as in the message).

Time is ``log.time_source``: ``"header"`` (the message's ``header.stamp``, the time the sample was taken) or
``"receive"`` (the recorder's receive time). Per topic, a stamp equal to the one kept before (duplicated) or
older than it (stale) drops its message. Signals whose stamps are all the same are merged as they are; otherwise
every signal is resampled by linear interpolation onto ``log.rate_hz`` over the time all topics overlap. Time 0 is
the first stamp kept (said in the notes). Each of these steps is said in the notes the importer
keeps in ``meta.options.import_notes``.

Every problem raises one :class:`~tendyn.io.logs.LogError` naming the map entry, the file and the topic.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from tendyn.io.logs import IMPORT_RATE_SLACK, LogError, rate_contradicts_time, time_column_rate

__all__ = ["BAG_SUFFIXES", "is_bag", "read_bag_signals", "field_value"]

BAG_SUFFIXES = (".bag", ".mcap", ".db3")
_TOKEN = re.compile(r"^([A-Za-z_][A-Za-z0-9_]*)((?:\[\d+\])*)$")


def is_bag(path: Path) -> bool:
    """A ROS 2 bag folder (with ``metadata.yaml``), or a ``.bag``, ``.mcap`` or ``.db3`` file."""
    path = Path(path)
    if path.is_dir():
        return True
    return path.suffix.lower() in BAG_SUFFIXES


class _Missing(Exception):
    """The message has the field but not this element (a shorter array): a missing sample."""


def _fields(msg) -> list[str]:
    return list(getattr(msg, "__dataclass_fields__", {}) or [a for a in vars(msg) if not a.startswith("_")])


def _parse_path(path: str) -> list:
    steps = []
    for part in path.split("."):
        m = _TOKEN.match(part.strip())
        if not m:
            raise ValueError(f"{path!r} is not a field path (names with dots, 0-based [k]: wrench.force.x, data[2])")
        steps.append(m.group(1))
        steps.extend(int(k) for k in re.findall(r"\[(\d+)\]", m.group(2)))
    return steps


def field_value(msg, steps: list, path: str) -> float:
    """The number at a parsed field path of a message; raises ValueError for a wrong path, _Missing for an
    element past the end of an array."""
    node = msg
    for st in steps:
        if isinstance(st, int):
            if not hasattr(node, "__len__") or isinstance(node, (str, bytes)):
                raise ValueError(f"{path!r}: [{st}] of a {type(node).__name__}, not an array")
            if st >= len(node):
                raise _Missing()
            node = node[st]
        else:
            if not hasattr(node, "__dataclass_fields__") or not hasattr(node, st):
                have = _fields(node) if hasattr(node, "__dataclass_fields__") else []
                raise ValueError(f"{path!r}: no field {st!r} in {getattr(node, '__msgtype__', type(node).__name__)}"
                                 + (f" (fields: {', '.join(have)})" if have else ""))
            node = getattr(node, st)
    if isinstance(node, np.ndarray) and node.ndim == 0:
        node = node[()]
    if isinstance(node, (bool, np.bool_)) or not isinstance(node, (int, float, np.integer, np.floating)):
        what = (f"an array of {len(node)}" if hasattr(node, "__len__") else
                f"a {node.__msgtype__}" if hasattr(node, "__msgtype__") else type(node).__name__)
        raise ValueError(f"{path!r} is {what}, not a number" + (" (add [k])" if hasattr(node, "__len__") else ""))
    return float(node)


def _stamp_ns(msg, topic) -> int:
    head = getattr(msg, "header", None)
    stamp = getattr(head, "stamp", None)
    if stamp is None:
        raise ValueError(f"{getattr(msg, '__msgtype__', '?')} on {topic} has no header.stamp: set "
                         "log.time_source = \"receive\"")
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


def _open(path: Path):
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS1_NOETIC if path.suffix.lower() == ".bag" else Stores.ROS2_HUMBLE)
    return AnyReader([path], default_typestore=store)


def _read_one_bag(fname: str, path: Path, entries: list, time_source: str, mapname: str, notes: list):
    """Series (stamps [ns], values) per entry of one bag file."""
    def err(where, problem):
        return LogError(f"{where}: {problem}", file=mapname)

    topics = sorted({e["topic"] for e in entries})
    steps = {}
    for e in entries:
        try:
            steps[e["signal"]] = _parse_path(e["field"])
        except ValueError as exc:
            raise err(f"{e['where']}.field", str(exc)) from None
    # rosbags raises many kinds of exceptions on a broken file (its own reader errors, struct, KeyError, …):
    # any of them while opening or reading is the file's problem, said in one line.
    try:
        reader = _open(path)
        reader.open()
    except Exception as exc:                    # noqa: BLE001 — a foreign parser; see above
        raise LogError(f"not a readable ROS bag ({type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''})",
                       file=fname) from None
    try:
        have = sorted({c.topic for c in reader.connections})
        for e in entries:
            if e["topic"] not in have:
                raise err(f"{e['where']}.topic", f"no topic {e['topic']!r} in {fname} (topics: {', '.join(have)})")
        conns = [c for c in reader.connections if c.topic in topics]
        stamps = {t: [] for t in topics}
        values = {e["signal"]: [] for e in entries}
        by_topic = {t: [e for e in entries if e["topic"] == t] for t in topics}
        try:
            it = reader.messages(connections=conns)
            for conn, recv_ns, raw in it:
                msg = reader.deserialize(raw, conn.msgtype)
                t = conn.topic
                try:
                    stamps[t].append(_stamp_ns(msg, t) if time_source == "header" else int(recv_ns))
                except ValueError as exc:
                    raise err("log.time_source", str(exc)) from None
                for e in by_topic[t]:
                    if e["joint"] is not None:
                        names = getattr(msg, "name", None)
                        if names is None or not isinstance(names, (list, tuple)):
                            raise err(f"{e['where']}.joint", f"{conn.msgtype} on {t} has no name array: joint is "
                                                             "for messages like sensor_msgs/JointState")
                        names = list(names)
                        if e["joint"] not in names:
                            v = np.nan
                        else:
                            try:
                                v = field_value(msg, [*steps[e["signal"]], names.index(e["joint"])], e["field"])
                            except _Missing:
                                v = np.nan
                            except ValueError as exc:
                                raise err(f"{e['where']}.field", f"{exc} ({conn.msgtype} on {t})") from None
                    else:
                        try:
                            v = field_value(msg, steps[e["signal"]], e["field"])
                        except _Missing:
                            v = np.nan
                        except ValueError as exc:
                            raise err(f"{e['where']}.field", f"{exc} ({conn.msgtype} on {t})") from None
                    values[e["signal"]].append(v)
        except LogError:
            raise
        except Exception as exc:                # noqa: BLE001 — a foreign parser (see above)
            raise LogError(f"not a readable ROS bag ({type(exc).__name__}: "
                           f"{str(exc).splitlines()[0] if str(exc) else ''})", file=fname) from None
    finally:
        reader.close()
    series = {}
    for t in topics:
        st = np.asarray(stamps[t], dtype=np.int64)
        if st.size == 0:
            raise err(f"{by_topic[t][0]['where']}.topic", f"topic {t!r} has no message in {fname}")
        keep = np.zeros(st.size, dtype=bool)
        last, dup, stale = None, 0, 0
        for k, s in enumerate(st):
            if last is None or s > last:
                keep[k], last = True, s
            elif s == last:
                dup += 1
            else:
                stale += 1
        if dup:
            notes.append(f"{fname} {t}: {dup} message(s) with a duplicated {time_source} stamp dropped "
                         "(the first kept)")
        if stale:
            notes.append(f"{fname} {t}: {stale} stale message(s) dropped (a {time_source} stamp older than the "
                         "one before)")
        for e in by_topic[t]:
            v = np.asarray(values[e["signal"]], dtype=np.float64)[keep]
            ok = ~np.isnan(v)
            what = f"joint {e['joint']!r} {e['field']}" if e["joint"] else e["field"]
            if not ok.any():
                raise err(f"{e['where']}.joint" if e["joint"] else f"{e['where']}.field",
                          f"{what} is in no message of {t} in {fname}")
            if not ok.all():
                notes.append(f"{fname} {t}: {what} missing from {int((~ok).sum())} of {ok.size} messages "
                             f"({e['signal']} has no sample there)")
            series[e["signal"]] = (st[keep][ok], v[ok])
    return series


def read_bag_signals(files: dict, targets: dict, spec: dict, mapname: str):
    """Columns (``time`` first, scale and offset applied), the rate [Hz] and the notes of a map's bag signals.

    Parameters
    ----------
    files : dict
        RAW file name → path.
    targets : dict
        Log signal → the RAW file name it comes from.
    spec : dict
        The checked import map (:func:`tendyn.io.importer.read_import_map`).
    mapname : str
        The map's file name (errors name it).
    """
    notes: list[str] = []
    entries = [s for s in spec["signals"] if s["topic"] is not None]
    series = {}
    for fname in sorted({targets[e["signal"]] for e in entries}):
        mine = [e for e in entries if targets[e["signal"]] == fname]
        series.update(_read_one_bag(fname, Path(files[fname]), mine, spec["log"]["time_source"], mapname, notes))
    rate = spec["log"].get("rate_hz")
    first = next(iter(series.values()))[0]
    same = all(st.size == first.size and np.array_equal(st, first) for st, _ in series.values())
    if same:
        origin = int(first[0])
        time = (first - origin).astype(np.float64) / 1e9
        if time.size < 2:
            raise LogError("one sample: a log needs at least two", file=mapname)
        from_time = time_column_rate(time)
        if rate is None:
            rate = from_time
        elif rate_contradicts_time(rate, time, IMPORT_RATE_SLACK):
            raise LogError(f"log.rate_hz: {rate:g} Hz, but the stamps are {from_time:g} Hz apart: remove "
                           "log.rate_hz (the stamps are the time) or fix it", file=mapname)
        cols = {"time": time}
        cols.update({sig: v for sig, (_, v) in series.items()})
        if len(series) > 1:
            notes.append(f"{len(series)} signals on identical stamps: merged without resampling")
    else:
        if rate is None:
            desc = "; ".join(f"{sig}: {st.size} stamps" for sig, (st, _) in series.items())
            raise LogError(f"log.rate_hz: required: the signals have different stamps ({desc}), so they are "
                           "resampled onto one grid at this rate [Hz]", file=mapname)
        start = max(int(st[0]) for st, _ in series.values())
        end = min(int(st[-1]) for st, _ in series.values())
        if end <= start:
            raise LogError("the topics do not overlap in time: nothing to merge", file=mapname)
        n = int(np.floor((end - start) * 1e-9 * rate * (1 + 1e-12))) + 1
        if n < 2:
            raise LogError(f"the topics overlap for {(end - start) * 1e-9:g} s: less than two samples at "
                           f"{rate:g} Hz", file=mapname)
        time = np.arange(n) / rate
        origin = start
        cols = {"time": time}
        for sig, (st, v) in series.items():
            cols[sig] = np.interp(time, (st - origin).astype(np.float64) / 1e9, v)
        notes.append(f"{len(series)} signals resampled onto {rate:g} Hz by linear interpolation over the "
                     f"{(time[-1]):g} s all topics overlap (their stamps differ)")
        cut = [f"{sig} {((start - st[0]) * 1e-9):g} s before, {((st[-1] - end) * 1e-9):g} s after"
               for sig, (st, _) in series.items() if st[0] < start or st[-1] > end]
        if cut:
            notes.append("outside the overlap, dropped: " + "; ".join(cut))
    by_sig = {e["signal"]: e for e in entries}
    for sig in list(cols):
        if sig != "time":
            cols[sig] = by_sig[sig]["scale"] * cols[sig] + by_sig[sig]["offset"]
    notes.append(f"time 0 = {spec['log']['time_source']} stamp {origin} ns")
    return cols, rate, notes
