"""The routing of a cable-driven device drawn as SVG: joints, pulleys and idle pulleys with radii to scale, each
cable's path and winding sense, reducers and motors (``tendyn routing show DEV --report DIR``, every report's index).

A leaf: it reads the device it is given (``device.transmissions``, ``device.joint_names``, ``device.n_plus_one``)
and imports nothing of tendyn. The drawing is a schematic in the way S0 (Fig. 2) draws its routing:

* one **column per joint** (a dash-dot axis, labelled ``J<j> <name>``): the pulleys on one column turn about that
  joint's axis; the motors sit on the base, at the left;
* one **row per transmission** (cable loop, antagonistic cable pair or N+1 tendon): its motor (a box ``M<i>``
  with the motor pulley, radius r_m), then one pulley on every joint its K row crosses: an **idle pulley** (white)
  on the joints it crosses, the **driven pulley** (filled) on the joint it drives, with a **reducer** box
  ``n = …`` when ``reducer_ratio`` ≠ 1;
* every radius to one scale (the scale bar says it); the **winding sense** is the side the cable passes: above the
  pulley for a positive radius, below for a negative one, so the two strands of a loop cross before a pulley wound
  the other way (S0 eq. 1: a negative signed radius); a loop closes round its last pulley, an N+1 tendon ends
  (a dot) on the pulley of the joint it ends on.

Each element carries its meaning for readers and tests: ``<g class="cable" data-transmission="2">`` holds the
cable's ``path`` and one ``class="wrap"`` arc per pulley it runs over (``data-joint``, ``data-sense``); joint axes
are ``class="joint-axis" data-joint=…`` lines. All text is escaped; the SVG needs no script and no font file.
"""

from __future__ import annotations

import math
from html import escape

__all__ = ["routing_svg", "has_routing"]

_PAD = 24.0


def _e(text) -> str:
    return escape(str(text), quote=True)


def has_routing(device) -> bool:
    """Whether the device has cables to draw (``[[transmissions]]``)."""
    return getattr(device, "kind", None) == "serial" and bool(getattr(device, "transmissions", None))


def _pulleys(t) -> list[tuple[int, float, str]]:
    """(joint number, signed radius [m], role) of one transmission, in joint order; the driven pulley's radius is
    the pulley's own (``driven_radius``), its reducer drawn apart."""
    out = [(int(j), float(r), "idle") for j, r in zip(t.crosses, t.crossed_radii)]
    out.append((int(t.joint), float(t.driven_radius), "driven"))
    return sorted(out)


def _arc(cx, cy, r, a0, a1, sweep) -> str:
    """An SVG arc of radius r about (cx, cy) from angle a0 to a1 [deg, y down]."""
    x0, y0 = cx + r * math.cos(math.radians(a0)), cy + r * math.sin(math.radians(a0))
    x1, y1 = cx + r * math.cos(math.radians(a1)), cy + r * math.sin(math.radians(a1))
    large = 1 if abs(a1 - a0) > 180 else 0
    return f"M{x0:.2f},{y0:.2f} A{r:.2f},{r:.2f} 0 {large} {sweep} {x1:.2f},{y1:.2f}"


def routing_svg(device, *, title: str | None = None) -> str | None:
    """The device's routing as an SVG document (a string), or None for a device without ``[[transmissions]]``
    (geared ``[[actuators]]``, capstan ``[[drives]]``, a tendon bench).

    Parameters
    ----------
    device : SerialDevice
        A loaded device (:func:`tendyn.devices.load`).
    title : str, optional
        The drawing's title (default: ``"<device name>: cable routing"``).
    """
    if not has_routing(device):
        return None
    trs = list(device.transmissions)
    names = list(getattr(device, "joint_names", ()))
    n_plus_one = bool(getattr(device, "n_plus_one", False))
    rows = [_pulleys(t) for t in trs]
    joints = sorted({j for row in rows for j, _, _ in row})
    r_max = max([abs(r) for row in rows for _, r, _ in row] + [abs(t.motor_radius) for t in trs])
    scale = 42.0 / r_max                                       # px per m: the largest pulley 42 px
    lane = 2 * 42.0 + 58.0
    col_w = 2 * 42.0 + 120.0
    motor_x = 190.0
    top = 92.0
    xs = {j: motor_x + col_w * (k + 1) for k, j in enumerate(joints)}
    width = motor_x + col_w * (len(joints) + 0.6) + _PAD
    height = top + lane * len(trs) + 86.0
    head = title if title is not None else f"{getattr(device, 'name', 'device')}: cable routing"
    kind = ("N+1 tendons (one strand each, pulled by its motor)" if n_plus_one else
            "antagonistic cable pairs (2N)" if any(getattr(t, "antagonistic", False) for t in trs) else
            "closed cable loops")
    out = [f'<svg xmlns="http://www.w3.org/2000/svg" class="routing" role="img" width="{width:.0f}" '
           f'height="{height:.0f}" viewBox="0 0 {width:.0f} {height:.0f}" font-family="sans-serif" font-size="12" '
           f'aria-label="{_e(head)}">',
           f"<title>{_e(head)}</title>",
           '<rect x="0" y="0" width="100%" height="100%" fill="#ffffff"/>',
           f'<text class="title" x="{_PAD}" y="24" font-size="16" font-weight="bold">{_e(head)}</text>',
           f'<text x="{_PAD}" y="44" fill="#444">{len(trs)} transmissions, {len(joints)} joints: {_e(kind)}; '
           'radii to scale; a cable passes above a pulley of positive radius, below one of negative radius</text>']
    # joint axes
    for j in joints:
        x = xs[j]
        label = names[j - 1] if 0 < j <= len(names) else ""
        out.append(f'<line class="joint-axis" data-joint="{j}" x1="{x:.2f}" y1="{top - 18:.2f}" x2="{x:.2f}" '
                   f'y2="{top + lane * len(trs):.2f}" stroke="#888" stroke-dasharray="10 4 2 4"/>')
        out.append(f'<text class="joint-label" data-joint="{j}" x="{x:.2f}" y="{top - 24:.2f}" '
                   f'text-anchor="middle" font-weight="bold">J{j} {_e(label)}</text>')
    palette = ["#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#17becf", "#8c564b", "#e377c2"]
    for i, (t, row) in enumerate(zip(trs, rows), start=1):
        y = top + lane * (i - 0.5)
        color = palette[(i - 1) % len(palette)]
        rm = abs(float(t.motor_radius)) * scale
        # motor, its pulley and its label
        out.append(f'<g class="motor" data-transmission="{i}">'
                   f'<rect x="{_PAD}" y="{y - 22:.2f}" width="{motor_x - _PAD - rm - 26:.2f}" height="44" rx="4" '
                   f'fill="#f4f4f4" stroke="#333"/>'
                   f'<text class="transmission-name" x="{_PAD + 6}" y="{y - 5:.2f}" font-weight="bold">'
                   f'M{i} {_e(t.name)}</text>'
                   f'<text x="{_PAD + 6}" y="{y + 12:.2f}" font-size="10" fill="#444">r_m {1e3 * t.motor_radius:g} mm'
                   f'{", 2N pair" if getattr(t, "antagonistic", False) else ""}</text>'
                   f'<line x1="{motor_x - rm - 26:.2f}" y1="{y:.2f}" x2="{motor_x:.2f}" y2="{y:.2f}" stroke="#333" '
                   f'stroke-width="3"/>'
                   f'<circle class="pulley motor-pulley" cx="{motor_x:.2f}" cy="{y:.2f}" r="{rm:.2f}" fill="#ddd" '
                   f'stroke="#333"/></g>')
        # pulleys
        for j, r, role in row:
            x, rr = xs[j], abs(r) * scale
            fill = color if role == "driven" else "#ffffff"
            out.append(f'<circle class="pulley {role}" data-transmission="{i}" data-joint="{j}" cx="{x:.2f}" '
                       f'cy="{y:.2f}" r="{rr:.2f}" fill="{fill}" fill-opacity="{0.35 if role == "driven" else 1}" '
                       f'stroke="#333"/>')
            out.append(f'<text x="{x + rr + 4:.2f}" y="{y + (rr + 14 if r > 0 else -rr - 6):.2f}" font-size="10" '
                       f'fill="#444">{1e3 * r:+g} mm</text>')
            n = float(getattr(t, "reducer_ratio", 1.0))
            if role == "driven" and n != 1.0:
                eta = float(getattr(t, "reducer_efficiency", 1.0))
                out.append(f'<g class="reducer" data-transmission="{i}" data-joint="{j}">'
                           f'<rect x="{x + rr + 10:.2f}" y="{y - 11:.2f}" width="70" height="22" fill="#fff6d5" '
                           f'stroke="#8a6d00"/><text x="{x + rr + 14:.2f}" y="{y + 4:.2f}" font-size="10">n = {n:g}, '
                           f'η {eta:g}</text></g>')
        # the cable: strand a from the motor's top, over (r > 0) or under (r < 0) each pulley
        pts = [(motor_x, y - rm)]
        for j, r, _ in row:
            pts.append((xs[j], y - (1 if r > 0 else -1) * abs(r) * scale))
        d = "M" + " L".join(f"{px:.2f},{py:.2f}" for px, py in pts)
        jl, rl, _ = row[-1]
        xl, rrl = xs[jl], abs(rl) * scale
        if not n_plus_one:
            back = [(motor_x, y + rm)] + [(xs[j], y + (1 if r > 0 else -1) * abs(r) * scale) for j, r, _ in row]
            side = 1 if rl > 0 else -1
            d += f" A{rrl:.2f},{rrl:.2f} 0 0 {1 if side > 0 else 0} {xl:.2f},{y + side * rrl:.2f}"
            d += " L" + " L".join(f"{px:.2f},{py:.2f}" for px, py in reversed(back[:-1]))
            d += f" A{rm:.2f},{rm:.2f} 0 0 1 {motor_x:.2f},{y - rm:.2f} Z"
        g = [f'<g class="cable" data-transmission="{i}" data-name="{_e(t.name)}">',
             f'<path class="cable-path" d="{d}" fill="none" stroke="{color}" stroke-width="2"/>']
        for k, (j, r, role) in enumerate(row):
            x, rr = xs[j], abs(r) * scale
            sense = "+" if r > 0 else "-"
            last = k == len(row) - 1
            if last and not n_plus_one:
                arc = _arc(x, y, rr, -90, 90, 1)                       # the loop closes round its last pulley
            else:
                centre = -90 if r > 0 else 90
                arc = _arc(x, y, rr, centre - 35, centre + 35, 1)      # the strand's contact on this pulley
            g.append(f'<path class="wrap" data-joint="{j}" data-sense="{sense}" data-role="{role}" d="{arc}" '
                     f'fill="none" stroke="{color}" stroke-width="5" stroke-linecap="round"/>')
            if last and n_plus_one:
                g.append(f'<circle class="anchor" cx="{x:.2f}" cy="{y - (1 if r > 0 else -1) * rr:.2f}" r="4" '
                         f'fill="{color}"/>')
        g.append("</g>")
        out += g
    # scale bar and legend
    yb = top + lane * len(trs) + 34
    decade = 10.0 ** math.floor(math.log10(r_max))
    bar_m = max(m * decade for m in (1, 2, 5) if m * decade <= r_max * (1 + 1e-9))
    out.append(f'<g class="scale"><line x1="{_PAD}" y1="{yb:.2f}" x2="{_PAD + bar_m * scale:.2f}" y2="{yb:.2f}" '
               f'stroke="#000" stroke-width="3"/><text x="{_PAD + bar_m * scale + 8:.2f}" y="{yb + 4:.2f}">'
               f'{1e3 * bar_m:g} mm (pulley radii to this scale)</text></g>')
    out.append(f'<text x="{_PAD}" y="{yb + 26:.2f}" font-size="11" fill="#444">filled: driven pulley (on its '
               'joint); white: idle pulley; crossed strands: winding reversed; n: reducer in the driven pulley; '
               f'{"a dot: where the tendon ends" if n_plus_one else "a loop closes round its last pulley"}</text>')
    out.append("</svg>")
    return "\n".join(out)
