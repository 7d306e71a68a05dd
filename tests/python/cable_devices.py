"""Seeded random cable devices written as device files (schema 1, standard DH, one transmission per joint).

``cable_device(rng, n, planar)``: n revolute joints with [[transmissions]] routed over signed idle pulleys,
reducers, per-branch friction (τ0, ν, β) and a motor with its rotor inertia. Planar: every axis parallel (α = 0),
the handle moves in a plane; spatial: α alternates ±π/2, so 3 joints move the handle in 3-D. The handle is the
last DH frame's origin (a_n along x_n). Nothing is taken from a bundled device.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np


def _value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    if isinstance(v, (float, np.floating)):
        return repr(float(v))
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{k} = {_value(x)}" for k, x in v.items()) + "}"
    raise TypeError(v)


def cable_device_text(rng, n: int, planar: bool, name: str | None = None, gravity=(0.0, 0.0, -9.81)) -> str:
    """The TOML text of a random n-joint cable device (module docstring)."""
    name = name or f"gen{n}{'p' if planar else 's'}"
    joints = []
    for j in range(n):
        alpha = 0.0 if planar or j == n - 1 else (-1) ** j * math.pi / 2
        a = float(rng.uniform(0.15, 0.35)) if (planar or j >= 1) else 0.0
        half = float(rng.uniform(0.9, 1.3))
        centre = float(rng.uniform(-0.3, 0.3)) + (0.9 if (planar and j >= 1) else 0.0)
        ixx = float(rng.uniform(0.003, 0.02))
        izz = float(rng.uniform(0.3, 1.8)) * ixx                  # principal moments within the triangle rule
        joints.append(dict(name=f"j{j + 1}", a=a, alpha=alpha, d=0.0, theta_offset=0.0,
                           lower=centre - half, upper=centre + half, mass=float(rng.uniform(0.3, 2.0)),
                           com=[-0.5 * a, 0.0, 0.0], inertia=[ixx, ixx, izz, 0.0, 0.0, 0.0]))
    lines = ["schema = 1", "", "[device]", f"name = {_value(name)}", 'description = "generated cable device"', "",
             "[kinematics]", 'convention = "dh"', f"gravity = {_value(list(gravity))}", ""]
    for js in joints:
        lines.append("[[kinematics.joints]]")
        lines += [f"{k} = {_value(v)}" for k, v in js.items()]
        lines.append("")
    for i in range(n):
        ratio = float(rng.choice([1.0, float(rng.uniform(3.0, 10.0))]))
        crossed = [float(rng.choice([-1, 1]) * rng.uniform(0.008, 0.02)) for _ in range(i)]
        fr = [dict(tau0=float(rng.uniform(0.2, 1.5)), nu=float(rng.uniform(2.0, 15.0)), beta=float(rng.uniform(0, 0.03)))
              for _ in range(i + 1)]
        lines += ["[[transmissions]]", f'name = "t{i + 1}"', f"joint = {i + 1}",
                  f"motor_radius = {float(rng.uniform(0.006, 0.012))!r}", f"crosses = {_value(list(range(1, i + 1)))}",
                  f"crossed_radii = {_value(crossed)}", f"driven_radius = {float(rng.uniform(0.02, 0.06))!r}",
                  f"reducer_ratio = {ratio!r}", f"reducer_efficiency = {0.9 if ratio > 1 else 1.0!r}",
                  f"pretension = {float(rng.uniform(10, 60))!r}", f"friction = {_value(fr)}",
                  "[transmissions.motor]", "torque_constant = 0.1",
                  f"rotor_inertia = {float(rng.uniform(2e-5, 2e-4))!r}", "continuous_torque = 0.7",
                  "peak_torque = 3.0", "[transmissions.sensors]", "encoder_counts = 16384", "current_noise = 0.07", ""]
    return "\n".join(lines)


def write_cable_device(tmp_path: Path, rng, n: int, planar: bool, **kw) -> Path:
    """Write :func:`cable_device_text` to ``tmp_path / NAME.toml`` and return the path."""
    text = cable_device_text(rng, n, planar, **kw)
    name = text.split('name = "', 1)[1].split('"', 1)[0]
    p = Path(tmp_path) / f"{name}.toml"
    p.write_text(text, encoding="utf-8")
    return p
