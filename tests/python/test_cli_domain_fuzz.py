"""The fuzz reads the domains (issue 34 item 2): for every command of the parser, every option whose converter
declares a :class:`tendyn.commands.args.Domain` (the options of tendyn.commands and simulate's catalogue) is given
values just outside its domain — exit 2, one line naming the option — and just inside — the converter accepts it
and the command never ends in an internal error (exit 3).

Seeded: ``TENDYN_FUZZ_SEED`` (default 34) draws the far-outside values and the sample the fast run takes; the count
and the seed are printed. ``pytest -m slow`` runs every case and more far-outside draws.
"""

from __future__ import annotations

import argparse
import math
import os
import random

import numpy as np
import pytest

from tendyn.cli import build_parser, main
from tendyn.commands.args import Domain

SEED = int(os.environ.get("TENDYN_FUZZ_SEED", "34"))
FAST_CASES = 160
"""Cases of the fast run (a seeded sample of all); the slow run takes every one."""


def commands(parser: argparse.ArgumentParser, path=()):
    subs = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    if not subs:
        yield path, parser
        return
    seen = set()
    for name, p in subs[0].choices.items():
        if id(p) not in seen:
            seen.add(id(p))
            yield from commands(p, path + (name,))


def _fmt(x, integer: bool) -> str:
    return str(int(x)) if integer else repr(float(x))


def outside(dom, rng: random.Random, far: int) -> list[str]:
    """Values just outside ``dom`` (at an open bound, one integer or one ulp past a closed one), ``far`` draws far
    outside, and non-numbers."""
    vals = []
    if dom.lo is not None:
        if dom.integer:
            vals.append(math.ceil(dom.lo) if dom.lo_open and float(dom.lo).is_integer() else math.ceil(dom.lo) - 1)
        else:
            vals.append(dom.lo if dom.lo_open else np.nextafter(dom.lo, -np.inf))
        vals += [dom.lo - abs(dom.lo or 1.0) * 10 ** rng.uniform(0, 6) for _ in range(far)]
    if dom.hi is not None:
        vals.append(math.floor(dom.hi) + 1 if dom.integer else np.nextafter(dom.hi, np.inf))
        vals += [dom.hi + abs(dom.hi or 1.0) * 10 ** rng.uniform(0, 6) for _ in range(far)]
    out = [_fmt(v, dom.integer) for v in vals]
    if dom.integer:
        out.append("1.5")
    else:
        out += ["nan", "inf"]
    if dom.many:
        good = inside(dom)[0]
        out = [f"{good},{v}" for v in out] + [f"{good},,{good}"]
        if dom.distinct:
            out.append(f"{good},{good}")
    return out


def inside(dom) -> list[str]:
    """Values just inside ``dom``: each closed bound, next to an open one, a middle value."""
    lo = dom.lo if dom.lo is not None else (-1.0 if dom.hi is None or dom.hi > -1 else dom.hi - 1)
    hi = dom.hi if dom.hi is not None else lo + 10.0
    vals = []
    if dom.integer:
        first = math.floor(lo) + 1 if dom.lo_open and float(lo).is_integer() else math.ceil(lo)
        vals += [first, math.floor(hi), (first + math.floor(hi)) // 2]
    else:
        vals += [np.nextafter(lo, np.inf) if dom.lo_open else lo, hi, lo + (hi - lo) / 3]
    return [_fmt(v, dom.integer) for v in vals]


def cases(far: int):
    """(words, flag, value, where) of every declared domain; a file's domain (it has ``outside()``/``inside()``:
    BoxesDomain) gives (suffix, content) pairs, written to a file by :func:`_run`."""
    rng = random.Random(SEED)
    out = []
    for words, parser in sorted(commands(build_parser()), key=lambda c: c[0]):
        for action in parser._actions:
            dom = getattr(action.type, "domain", None)
            if dom is None or not action.option_strings:
                continue
            flag = max(action.option_strings, key=len)
            if not isinstance(dom, Domain):
                out += [(words, flag, v, "outside") for v in dom.outside()]
                out += [(words, flag, v, "inside") for v in dom.inside()]
                continue
            out += [(words, flag, v, "outside") for v in outside(dom, rng, far)]
            out += [(words, flag, v, "inside") for v in inside(dom)]
    return out


def _run(capsys, words, flag, value, where, converter):
    if isinstance(value, tuple):                # a file's content: written in the case's folder (the cwd)
        suffix, text = value
        path = f"domain_case{abs(hash(value)) % 10**8}{suffix}"
        with open(path, "w", encoding="utf-8") as fh:
            fh.write(text)
        value = path
    code = main([*words, f"{flag}={value}"])
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    shown = f"{' '.join(words)} {flag}={value} ({where}): exit {code}\n{err[-1500:]}"
    assert code != 3 and "Traceback" not in err, shown
    if where == "outside":
        assert code == 2 and len(lines) == 1 and lines[0].startswith("tendyn: error:") and flag in lines[0], shown
    else:
        converter(value)                        # the declared domain accepts it (raises otherwise)
    return code


def _converters():
    out = {}
    for words, parser in commands(build_parser()):
        for a in parser._actions:
            if getattr(a.type, "domain", None) is not None and a.option_strings:
                out[(words, max(a.option_strings, key=len))] = a.type
    return out


def _fuzz(capsys, tmp_path, monkeypatch, n_cases, far):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path / "xdg"))
    every = cases(far)
    picked = every if n_cases is None else random.Random(SEED).sample(every, min(n_cases, len(every)))
    conv = _converters()
    counts = {"outside": 0, "inside": 0}
    for words, flag, value, where in picked:
        _run(capsys, words, flag, value, where, conv[(words, flag)])
        counts[where] += 1
    with capsys.disabled():
        print(f"\ndomain fuzz: {len(picked)} of {len(every)} cases ({counts['outside']} outside, {counts['inside']} "
              f"inside), {len({(w, f) for w, f, _, _ in every})} options, seed {SEED}")
    written = [p for p in tmp_path.glob("*.*") if p.suffix in (".csv", ".json") and not p.name.startswith("domain_case")]
    assert not written, written


def test_every_declared_domain_is_fuzzed(capsys, tmp_path, monkeypatch):
    _fuzz(capsys, tmp_path, monkeypatch, FAST_CASES, far=1)


def test_every_file_domain_is_fuzzed(capsys, tmp_path, monkeypatch):
    """The file domains (``identify --bounds``: BoxesDomain) every case, in the fast run too (few, quick)."""
    monkeypatch.chdir(tmp_path)
    conv = _converters()
    picked = [c for c in cases(far=0) if isinstance(c[2], tuple)]
    assert {(w, f) for w, f, _, _ in picked} >= {(("identify",), "--bounds")}
    for words, flag, value, where in picked:
        _run(capsys, words, flag, value, where, conv[(words, flag)])


@pytest.mark.slow
def test_every_declared_domain_is_fuzzed_long(capsys, tmp_path, monkeypatch):
    _fuzz(capsys, tmp_path, monkeypatch, None, far=6)


def test_the_domains_cover_the_options():
    """Every numeric option of tendyn.commands and simulate declares its domain (a new one without is caught)."""
    opts = {(w, max(a.option_strings, key=len)) for w, p in commands(build_parser()) for a in p._actions
            if getattr(a.type, "domain", None) is not None and a.option_strings}
    assert len(opts) >= 60, len(opts)
    for must in [(("plan",), "--amplitude"), (("plan",), "--iterations"), (("frf",), "--segment"),
                 (("simulate",), "--rate"), (("export",), "--timestep"), (("identify",), "--bounds")]:
        assert must in opts, must


# ---- relations with the device (args.DEVICE_LIMITS): read from the table, tried just outside and just inside -----

def _limit_argv(command, option, value, dev, tmp_path, kind):
    """A command line whose only questionable input is ``--option=value`` (``sweep`` inside its limit then stops at
    a bad --param, after the limit check, so no Dask run starts)."""
    flag = "--" + option.replace("_", "-")
    if command == "plan":
        extra = {"prbs": ["--duration", "0.01"], "multisine": ["--duration", "0.1", "--band", "1,10"],
                 "stepped-sine": ["--frequencies", "50", "--cycles", "1", "--settle", "0"]}[kind]
        return ["plan", kind, str(dev), f"{flag}={value}", *extra, "--out", str(tmp_path / "ref.csv")]
    assert command == "sweep", command                  # a new DEVICE_LIMITS row needs its command line here
    return ["sweep", str(dev), f"{flag}={value}", "--param", "no_such_field=1:2:2", "--out",
            str(tmp_path / "s.parquet")]


def _device_limit_cases():
    from tendyn.commands.args import DEVICE_LIMITS

    kinds = {"plan": ("prbs", "multisine", "stepped-sine"), "sweep": (None,)}
    return [(c, o, f, k) for c, row in DEVICE_LIMITS.items() for o, f in row.items() for k in kinds[c]]


@pytest.mark.parametrize("command, option, field, kind", _device_limit_cases())
def test_device_limits_just_outside_and_inside(capsys, tmp_path, monkeypatch, command, option, field, kind):
    """Each DEVICE_LIMITS row on a generated bench (seeded): the field's value read from the file itself (tomllib,
    not tendyn's loader) is the limit; one ulp and 1e-6 above → exit 2, one line naming the option, the value, the
    limit and the field; at the limit and a third of it → not refused for this option. A bench without the field
    keeps only the fixed bound. (Plants seen failing: the relation dropped; compared with peak_force/ratio, with
    peak_force + pretension, and in kN.)"""
    import tomllib

    from tendyn.devices.generate import write_tendon_bench

    monkeypatch.chdir(tmp_path)
    rng = random.Random(SEED)
    dev = write_tendon_bench(tmp_path, seed=rng.randrange(1000))
    limit = tomllib.loads(dev.read_text())["bench"][field]
    flag = "--" + option.replace("_", "-")
    for value in (np.nextafter(limit, np.inf), limit * (1 + 1e-6), limit * 10.0):
        code = main(_limit_argv(command, option, repr(float(value)), dev, tmp_path, kind))
        lines = capsys.readouterr().err.strip().splitlines()
        assert code == 2 and len(lines) == 1, (value, lines)
        for part in (flag, repr(float(value)), repr(float(limit)), f"bench.{field}"):
            assert part in lines[0], (part, lines[0])
    for value in (limit, limit / 3.0):
        code = main(_limit_argv(command, option, repr(float(value)), dev, tmp_path, kind))
        err = capsys.readouterr().err
        assert code != 3 and "Traceback" not in err and flag not in err, (value, err)
        assert code == 0 if command == "plan" else "--param" in err, (value, code, err)
    nolimit = write_tendon_bench(tmp_path, seed=1, name="nolimit", peak_force=False)
    code = main(_limit_argv(command, option, repr(limit * 10.0), nolimit, tmp_path, kind))
    err = capsys.readouterr().err
    assert code != 3 and flag not in err, err
    with capsys.disabled():
        print(f"\ndevice limit {command} {kind or ''} {flag} ≤ bench.{field} = {limit:.6g}: 3 outside, 2 inside, "
              f"seed {SEED}")


# ---- options that need or exclude another (args.OPTION_NEEDS, OPTION_EXCLUDES): read from the tables ----------

_ARGV = {"identify": ["identify", "no_such_device", "log.csv"], "zwidth": ["zwidth", "no_such_device"],
         "export": ["export", "compensator", "no_such_device", "--out", "x.comp"]}
"""The command line of each command of the tables (a device that does not exist; log.csv is written by the test,
its content never read): a new command needs one here."""


def _needs_cases():
    from tendyn.commands.args import OPTION_NEEDS

    return [(c, o, f) for c, row in OPTION_NEEDS.items() for o, (f, _) in row.items()]


def _excludes_cases():
    from tendyn.commands.args import OPTION_EXCLUDES

    return [(c, o, f) for c, row in OPTION_EXCLUDES.items() for o, (f, _) in row.items()]


def _given(command, dest, tmp_path):
    """[flag, value] of option ``dest`` with a value inside its domain (a file written here when it takes one), or
    [flag] for a switch."""
    action = [a for w, p in commands(build_parser()) if w == (command,) for a in p._actions if a.dest == dest][0]
    flag = max(action.option_strings, key=len)
    if action.nargs == 0:
        return [flag]
    domain = getattr(action.type, "domain", None)
    name, text = domain.inside()[0] if domain is not None else (f"{dest}.json", "{}")
    path = tmp_path / f"v{name}"
    path.write_text(text, encoding="utf-8")
    return [flag, str(path)]


@pytest.mark.parametrize("command, option, needed", _needs_cases())
def test_option_needs_its_flag(capsys, tmp_path, monkeypatch, command, option, needed):
    """Each OPTION_NEEDS row: the option given with a value inside its domain but without the one it needs → exit
    2, one line naming both, before the DEVICE is read (a device that does not exist); with the other given too,
    the line is no longer about the option (the missing device is)."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "log.csv").write_text("time\n0\n", encoding="utf-8")
    opt, need = _given(command, option, tmp_path), _given(command, needed, tmp_path)
    code = main([*_ARGV[command], *opt])
    lines = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(lines) == 1 and opt[0] in lines[0] and need[0] in lines[0], lines
    code = main([*_ARGV[command], *opt, *need])
    lines = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(lines) == 1 and "no_such_device" in lines[0] and opt[0] not in lines[0], lines


@pytest.mark.parametrize("command, option, excluded", _excludes_cases())
def test_option_excludes_the_other(capsys, tmp_path, monkeypatch, command, option, excluded):
    """Each OPTION_EXCLUDES row: both options given (values inside their domains) → exit 2, one line naming both,
    before the DEVICE is read; either one alone gets as far as the missing device."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "log.csv").write_text("time\n0\n", encoding="utf-8")
    opt, other = _given(command, option, tmp_path), _given(command, excluded, tmp_path)
    code = main([*_ARGV[command], *opt, *other])
    lines = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(lines) == 1 and opt[0] in lines[0] and other[0] in lines[0], lines
    for alone in (opt, other):
        code = main([*_ARGV[command], *alone])
        lines = capsys.readouterr().err.strip().splitlines()
        assert code == 2 and len(lines) == 1 and "no_such_device" in lines[0], lines


def test_every_commands_help_renders():
    """`tendyn COMMAND --help` of every command and subcommand (walked from the parser): argparse %-formats each
    help text, so a bare % in one ("0.25 %, 10 %") made `identify -h` an internal error (exit 3); every option's
    flag is listed."""
    for path, parser in commands(build_parser()):
        text = parser.format_help()
        for action in parser._actions:
            if action.option_strings and action.help != argparse.SUPPRESS:
                assert max(action.option_strings, key=len) in text, (path, action.option_strings)
