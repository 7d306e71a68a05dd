"""`[[terms]]` expressions evaluated safely in bounded time (issue 34 item 3).

A device file is input from anyone: its expressions are evaluated in float64 only (no Python integers, so a power
tower overflows instead of spinning), bounded in length, node count and depth before and after parsing, checked
finite over each joint's range once at load, and a ``table`` term's knots are bounded. Every refusal is one line
(exit 2) within a second of CPU time (process time: robust to a loaded machine), from ``routing show`` (which
loads the file) and from ``load_device``.
"""

from __future__ import annotations

import time

import numpy as np
import pytest

from tendyn.cli import main
from tendyn.device import DeviceError, load_device
from tendyn.device.terms import MAX_KNOTS, check_expression, evaluate_expression, hat_basis
from tendyn.devices.generate import cable_device_toml


def _device(tmp_path, terms: str):
    p = tmp_path / "dev.toml"
    p.write_text(cable_device_toml(2, name="exprs") + "\n" + terms)
    return p


def _function(expr: str) -> str:
    return f'[[terms]]\nname = "s"\nkind = "functions"\njoint = 1\nfunctions = ["{expr}"]\n'


BAD_EXPRESSIONS = {
    "power tower": ("9**9**9**9", "overflows"),
    "integer tower": ("2**2**2**2**2**2", "overflows"),
    "tower of q": ("(q+9)**(q+9)**(q+9)**9", "overflows"),
    "exp tower": ("exp(exp(exp(q)))", "overflows"),
    "100k unary": ("-" * 100_000 + "q", "characters"),
    "100k chain": ("q+" * 50_000 + "q", "characters"),
    "deep nesting": ("-" * 150 + "q", "nested deeper"),
    "many nodes": ("+".join(["q"] * 150), "allowed"),
    "huge literal": ("1" * 300 + "*q", "beyond"),
    "inf literal": ("1e999*q", "beyond"),
    "division by zero": ("q/0", "divides by zero"),
    "zero denominator": ("1/(q-q)", "divides by zero"),
    "0 to a negative power": ("0**-1 + q", "divides by zero"),
    "log of negative": ("log(q)", "undefined"),
    "overflow": ("1e9**40*q", "overflows"),
}


@pytest.mark.parametrize("case", sorted(BAD_EXPRESSIONS))
def test_bad_expression_refused_in_one_line_within_a_second(tmp_path, capsys, case):
    expr, msg = BAD_EXPRESSIONS[case]
    p = _device(tmp_path, _function(expr))
    t0 = time.process_time()
    with pytest.raises(DeviceError) as e:
        load_device(p)
    assert time.process_time() - t0 < 1.0
    assert e.value.field == "terms[1].functions[1]" and msg in e.value.problem, str(e.value)
    t0 = time.process_time()
    code = main(["routing", "show", str(p)])
    err = capsys.readouterr().err
    assert time.process_time() - t0 < 1.0
    assert code == 2 and err.count("\n") == 1 and err.startswith("tendyn: error:") and len(err) < 400, err


def test_known_function_checked_like_functions(tmp_path):
    p = _device(tmp_path, '[[terms]]\nname = "k"\nkind = "known"\njoint = 2\nfunction = "1/(q1-q1)"\n')
    with pytest.raises(DeviceError) as e:
        load_device(p)
    assert e.value.field == "terms[1].function" and "divides by zero" in e.value.problem


def test_table_with_100k_knots_refused_without_allocating(tmp_path):
    knots = ", ".join(f"{x:.6f}" for x in np.linspace(-3, 3, 100_000))
    p = _device(tmp_path, f'[[terms]]\nname = "t"\nkind = "table"\njoint = 1\nknots = [{knots}]\n')
    t0 = time.process_time()
    with pytest.raises(DeviceError) as e:
        load_device(p)
    assert time.process_time() - t0 < 3.0            # mostly the TOML parse of 100k numbers
    assert e.value.field == "terms[1].knots" and f"more than the {MAX_KNOTS}" in e.value.problem


def test_table_at_the_knot_bound_loads_and_tabulates(tmp_path):
    """MAX_KNOTS knots are inside the domain: the file loads and the twin's tables are built (no n × n eye)."""
    from tendyn.device import compile_device
    from tendyn.device.terms import TermModel

    knots = np.linspace(-3, 3, MAX_KNOTS)
    p = _device(tmp_path, f'[[terms]]\nname = "t"\nkind = "table"\njoint = 1\nknots = [{", ".join(map(str, knots))}]\n'
                          f'values = [{", ".join(str(np.sin(k)) for k in knots)}]\n')
    tm = TermModel(compile_device(load_device(p)))
    lo, step, table = tm.joint_tables()
    x = lo[0] + step[0] * np.arange(table.shape[1])
    inside = (x > -3) & (x < 3)
    np.testing.assert_allclose(table[0][inside], np.interp(x[inside], knots, np.sin(knots)), atol=1e-12)


def test_hat_basis_is_linear_interpolation():
    """The banded hat basis against np.interp of every unit vector (the former dense construction)."""
    rng = np.random.default_rng(3)
    knots = np.sort(rng.uniform(-2, 2, 9))
    x = rng.uniform(-3, 3, 200)
    B = hat_basis(x, knots)
    dense = np.column_stack([np.interp(x, knots, e) for e in np.eye(knots.size)])
    np.testing.assert_allclose(B, dense, atol=1e-14)


def test_good_expressions_still_work():
    for text in ("cos(q) + 0.5*sin(q1)**2", "q**3 - 2*q", "sqrt(abs(q)) * sign(q)", "tanh(10*q)", "pi*q/2"):
        check_expression(text, 2)
    q = np.linspace(-1, 1, 5)
    np.testing.assert_allclose(evaluate_expression("q**3 - 2*q", q, {}), q ** 3 - 2 * q)
    # integer literals are floats: 2**-1 is 0.5, 7/2 is 3.5
    np.testing.assert_allclose(evaluate_expression("2**-1 + 7/2 + 0*q", q, {}), 4.0)
