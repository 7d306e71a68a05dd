"""Names have a declared domain and text from a file never drives the terminal (issue 36 item 3, docs/security.md):
a name is printable characters only (no control character, no newline), at most 200 characters, refused at load
in one line naming the field; whatever reaches the terminal from a file shows its control characters as escapes.
"""

from __future__ import annotations

import io
import json
from contextlib import redirect_stderr, redirect_stdout

import pytest

from tendyn.text import NAME_MAX_CHARS, name_problem, printable, text_problem

ESCAPES = ("\x1b]0;pwned\x07", "\x1b[2J", "a\nb", "tab\there", "\u202eevil", "\x9b2J", "\x00")


def _cli(argv):
    from tendyn.cli import main

    out, err = io.StringIO(), io.StringIO()
    with redirect_stdout(out), redirect_stderr(err):
        code = main(argv)
    return code, out.getvalue(), err.getvalue()


@pytest.mark.parametrize("bad", ESCAPES)
def test_name_with_a_control_character_is_refused_at_load_in_one_line(tmp_path, bad):
    """Each of device, joint and transmission names: exit 2, one line naming the field, the value escaped."""
    from tendyn.devices.generate import cable_device_toml

    base = cable_device_toml(2, seed=1)
    for field, old in (("device.name", 'name = "gen2p1"'), ("kinematics.joints[2].name", 'name = "j2"'),
                       ("transmissions[1].name", 'name = "t1"')):
        path = tmp_path / "dev.toml"
        path.write_text(base.replace(old, f"name = {json.dumps(bad + ' x')}"), encoding="utf-8")
        code, out, err = _cli(["routing", "show", str(path)])
        assert code == 2 and out == "", (field, err)
        assert err.count("\n") == 1 and err.startswith(f"tendyn: error: dev.toml: {field}: must be printable"), err
        assert not any(c in err[:-1] for c in "\x1b\x07\x00\x9b\u202e\n\t"), repr(err)


def test_name_length_and_the_domain_itself():
    assert name_problem("<script>alert(1)</script> é ✓") is None          # markup is text: the pages escape it
    assert name_problem("x" * NAME_MAX_CHARS) is None
    assert "at most 200" in name_problem("x" * (NAME_MAX_CHARS + 1))
    assert name_problem("  ") == "must not be empty"
    for bad in ESCAPES:
        assert name_problem(bad) is not None, repr(bad)
    assert text_problem("two\nlines\tand a tab") is None and text_problem("\x1b[2J") is not None


def test_bench_and_description_domains(tmp_path):
    """The tendon bench's own loader and a description (free text) keep the same domains."""
    from tendyn.device import DeviceError, load_device
    from tendyn.devices import bundled

    text = bundled("mcgill_bench").read_text(encoding="utf-8")
    path = tmp_path / "bench.toml"
    path.write_text(text.replace('name = "McGill 2N tendon bench"', 'name = "\\u001b]0;x\\u0007"', 1),
                    encoding="utf-8")
    with pytest.raises(DeviceError, match=r"device\.name: must be printable"):
        load_device(path)
    from tendyn.devices.generate import cable_device_toml

    path.write_text(cable_device_toml(2).replace('description = "', 'description = "\\u001b[2J', 1), encoding="utf-8")
    with pytest.raises(DeviceError, match=r"device\.description: must be text without control"):
        load_device(path)


def test_printable_escapes_every_control_character():
    assert printable("\x1b]0;pwned\x07 ok") == "\\x1b]0;pwned\\x07 ok"
    assert printable("a\nb\tc") == "a\nb\tc" and printable("a\nb", keep="") == "a\\x0ab"
    assert printable("\u202e\x9b\x7f") == "\\u202e\\x9b\\x7f"
    assert printable("<b>é ✓</b>") == "<b>é ✓</b>"


def test_a_path_with_escapes_reaches_the_terminal_escaped(tmp_path):
    """A folder name is any bytes but / and NUL: the error line that names it shows its escapes as text."""
    folder = tmp_path / "\x1b]0;pwned\x07\x1b[2J"
    code, _, err = _cli(["routing", "show", str(folder / "missing.toml")])
    assert code == 2 and "\x1b" not in err and "\x07" not in err and "\\x1b]0;pwned\\x07" in err, repr(err)


def test_routing_show_prints_hostile_markup_names_as_they_are(tmp_path):
    """Markup is printable: `routing show` prints it unchanged (it is the pages' job to escape it)."""
    from tendyn.devices.generate import cable_device_toml

    path = tmp_path / "dev.toml"
    path.write_text(cable_device_toml(2).replace('name = "t1"', 'name = "<b>t1</b>"'), encoding="utf-8")
    code, out, err = _cli(["routing", "show", str(path)])
    assert code == 0 and "<b>t1</b>" in out, err


def test_a_term_expression_is_bounded(tmp_path):
    """What tendyn evaluates from a file: expressions of q, bounded by their length. A power of integer
    constants (9**9**9, which Python would compute for ever) is refused at load in one line (it hung before)."""
    from tendyn.devices.generate import cable_device_toml

    for expr, why in (("9**9**9*q", "overflows"), ("q" + "+q" * 600, "more than the 400")):   # terms.py limits
        path = tmp_path / "dev.toml"
        path.write_text(cable_device_toml(2) + f'[[terms]]\nname = "g"\nkind = "functions"\njoint = 1\n'
                        f'functions = ["{expr}"]\n', encoding="utf-8")
        code, out, err = _cli(["routing", "show", str(path)])
        assert code == 2 and err.count("\n") == 1 and "terms[1].functions[1]" in err and why in err, err


class _Terminal(io.StringIO):
    def isatty(self):
        return True


def test_stdout_on_a_terminal_shows_no_control_character(tmp_path):
    """Any printer, not only those that call printable: on a terminal, stdout escapes control characters (here
    the path `simulate` prints, in a folder named with escape sequences); a pipe gets the bytes unchanged."""
    from tendyn.cli import main

    folder = tmp_path / "\x1b]0;pwned\x07\x1b[2J"
    folder.mkdir()
    argv = ["simulate", "mcgill_bench", "prbs", "--torque", "1", "--duration", "0.2", "--quiet", "--out",
            str(folder / "x.csv")]
    for stream, raw in ((_Terminal(), False), (io.StringIO(), True)):
        with redirect_stdout(stream), redirect_stderr(io.StringIO()):
            assert main(argv) == 0
        out = stream.getvalue()
        assert ("\x1b" in out) == raw and ("\\x1b]0;pwned\\x07" in out) != raw and "\n" in out, repr(out)
