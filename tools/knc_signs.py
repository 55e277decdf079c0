"""Sign pictures of the K&C report (``docs/knc/*.png``, used by ``docs/knc.md``).

``python tools/knc_signs.py [OUT_DIR]`` (default ``docs/knc``) draws three
schematic views of the LEFT front wheel in ISO 8855 (x forward, y left, z up), each
quantity drawn with the sense in which it is positive:

* ``front_view.png`` (from in front, looking rearward: the vehicle's left on the right):
  camber, kingpin inclination, scrub radius (SAE), track change, roll centre;
* ``side_view.png`` (looking from the left, forward to the left of the page): caster,
  trail, the anti-dive force line (contact patch to the side-view instant centre) and
  the anti-lift line (wheel centre to it);
* ``top_view.png`` (from above, forward up the page): toe-in, steer angle, the
  compliance loads in each wheel's own sense (Fx forward, Fy outboard, Mz toe-out) and
  the Ackermann construction.

The drawings are schematic (angles exaggerated), not to scale.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from suspenv.reports._mpl import pyplot, save_figure

DPI = 80
BLUE, RED, GREEN, GREY = "#1f5fa8", "#c0392b", "#1e8449", "#7f8c8d"


def _arrow(ax, p, q, color, text=None, where=0.5, off=(0, 0), **kw) -> None:
    ax.annotate(
        "", xy=q, xytext=p, arrowprops={"arrowstyle": "->", "color": color, "lw": 1.6, **kw}
    )
    if text:
        m = (1 - where) * np.asarray(p) + where * np.asarray(q)
        ax.text(m[0] + off[0], m[1] + off[1], text, color=color, fontsize=9)


def _dim(ax, x0, x1, y, color, text) -> None:
    """A dimension line from x0 to x1 at height y, positive from x0 towards x1."""
    ax.annotate("", xy=(x1, y), xytext=(x0, y), arrowprops={"arrowstyle": "<->", "color": color})
    ax.text(0.5 * (x0 + x1), y - 28, text, color=color, fontsize=9, ha="center", va="top")


def front_view(path: Path) -> None:
    """The left wheel seen from in front of the car (looking rearward): the vehicle
    centreline on the left of the page, the wheel's outboard (ISO +y) to the right."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6.4, 4.8))
    gam = np.deg2rad(-4.0)  # camber: top inboard (negative), exaggerated
    wc = np.array([700.0, 300.0])  # (y_out, z) mm
    R = 300.0
    up = np.array([np.sin(gam), np.cos(gam)])  # wheel plane's upward direction
    ax.plot(*np.c_[wc - R * up, wc + R * up], color="k", lw=6, alpha=0.25)
    ax.axhline(0, color=GREY, lw=1)
    ax.axvline(0, color=GREY, lw=1, ls="--")
    ax.text(5, 560, "vehicle centreline", color=GREY, fontsize=8)
    ax.text(420, -45, "pad plane (ground)", color=GREY, fontsize=8, ha="right")
    P = np.array([wc[0] - wc[1] * np.tan(gam), 0.0])  # loaded contact point
    ax.plot(*P, "ko")
    ax.text(P[0] + 8, P[1] - 40, "P: loaded\ncontact point", fontsize=8)
    ax.plot([wc[0], wc[0]], [wc[1], wc[1] + 230], color=GREY, lw=0.8)
    _arrow(ax, wc, wc + 230 * up, BLUE, "camber < 0:\ntop inboard", where=1.0, off=(20, -60))
    # steering axis, kingpin inclination
    B = np.array([640.0, 120.0])
    T = np.array([560.0, 560.0])
    k = (T - B) / np.linalg.norm(T - B)
    g = B + (0 - B[1]) / k[1] * k  # meets the ground
    ax.plot(*np.c_[g, T], color=RED, lw=1.5)
    ax.plot([T[0], T[0]], [T[1] - 150, T[1]], color=GREY, lw=0.8)
    ax.text(T[0] - 20, T[1] + 8, "KPI > 0: axis top inboard", color=RED, fontsize=9, ha="right")
    _dim(ax, g[0], P[0], -20, RED, "scrub radius > 0 (SAE):\naxis meets ground inboard of P")
    # roll centre: line from P to the front-view instant centre, to the centreline
    ic = np.array([-1500.0, 120.0])
    h = P[1] + (ic[1] - P[1]) * (0 - P[0]) / (ic[0] - P[0])
    ax.plot([P[0], 0], [P[1], h], color=GREEN, lw=1.2, ls="--")
    ax.plot(0, h, "o", color=GREEN)
    ax.text(
        10, h + 12, "roll centre: height above the ground > 0\n(line from P towards the "
        "instant centre)", color=GREEN, fontsize=8,
    )  # fmt: skip
    _arrow(
        ax,
        P + np.array([60, 60]),
        P + np.array([100, 60]),
        GREY,
        "track change > 0:\nP outboard in bump",
        where=1.0,
        off=(8, -10),
    )  # noqa: E501
    ax.set_xlim(-60, 900)
    ax.set_ylim(-110, 640)
    ax.set_aspect("equal")
    ax.set_xlabel("y outboard [mm] (left wheel: ISO +y)")
    ax.set_ylabel("z up [mm]")
    ax.set_title("Front view of the left wheel (from in front, looking rearward)", fontsize=10)
    save_figure(fig, path, dpi=DPI, tight=True)


def side_view(path: Path) -> None:
    """Left wheel seen from its left side: forward (+x) to the left of the page."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6.4, 4.8))
    R = 300.0
    wc = np.array([0.0, R])  # (x forward, z)
    t = np.linspace(0, 2 * np.pi, 200)
    ax.plot(-(wc[0] + R * np.cos(t)), wc[1] + R * np.sin(t), color="k", lw=6, alpha=0.25)
    ax.axhline(0, color=GREY, lw=1)
    # page x = -x_vehicle (forward to the left)
    X = lambda x: -x  # noqa: E731
    ax.plot(X(0), 0, "ko")
    ax.text(X(0) - 10, -35, "P", fontsize=9)
    cas = np.deg2rad(8.0)
    B = np.array([15.0, 120.0])
    k = np.array([-np.sin(cas), np.cos(cas)])  # axis top rearward
    T = B + 480 * k
    g = B + (0 - B[1]) / k[1] * k
    ax.plot([X(g[0]), X(T[0])], [g[1], T[1]], color=RED, lw=1.5)
    ax.plot([X(T[0]), X(T[0])], [T[1] - 160, T[1]], color=GREY, lw=0.8)
    ax.text(X(T[0]) + 10, T[1] + 5, "caster > 0: axis top rearward", color=RED, fontsize=9)
    ax.annotate("", xy=(X(0), -15), xytext=(X(g[0]), -15),
                arrowprops={"arrowstyle": "<->", "color": RED})  # fmt: skip
    ax.text(X(g[0]) - 5, -70, "trail > 0: axis meets the\nground ahead of P", color=RED,
            fontsize=9, ha="center")  # fmt: skip
    ic = np.array([-900.0, 260.0])  # side-view instant centre behind the wheel
    ax.plot([X(0), X(ic[0])], [0, ic[1]], color=GREEN, ls="--", lw=1.2)
    ax.plot([X(wc[0]), X(ic[0])], [wc[1], ic[1]], color=BLUE, ls=":", lw=1.2)
    ax.plot(X(ic[0]), ic[1], "o", color=GREEN)
    ax.text(X(ic[0]) + 30, ic[1] + 25, "side-view instant centre", color=GREEN, fontsize=8,
            ha="right")  # fmt: skip
    ax.text(X(-330), 30, "anti-dive > 0: the carrier's patch point\nmoves forward in bump "
            "(dx/dz > 0)", color=GREEN, fontsize=8)  # fmt: skip
    ax.text(X(-420), 420, "anti-lift > 0: the wheel centre\nmoves forward in bump",
            color=BLUE, fontsize=8)  # fmt: skip
    _arrow(ax, (X(0) - 150, 520), (X(0) - 250, 520), GREY, "forward (+x)", where=1.0, off=(-10, 10))
    ax.set_xlim(X(350), X(-1000))
    ax.xaxis.set_major_formatter(lambda v, _pos: f"{-v:g}")  # ticks show vehicle x
    ax.set_ylim(-110, 700)
    ax.set_aspect("equal")
    ax.set_xlabel("x [mm] (forward to the left)")
    ax.set_ylabel("z up [mm]")
    ax.set_title("Side view of the left wheel, from the left", fontsize=10)
    save_figure(fig, path, dpi=DPI, tight=True)


def top_view(path: Path) -> None:
    """Both front wheels from above: forward up the page, left wheel on the left."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6.4, 4.8))
    half = 700.0
    L = 2600.0
    for side, yc in (("left", -half), ("right", half)):  # page x = -y (left on the left)
        toe = np.deg2rad(6.0)  # toe-in, exaggerated
        # the front of each wheel turned inboard
        d = np.array([np.sin(toe) if side == "left" else -np.sin(toe), np.cos(toe)])
        ax.plot([yc - 260 * d[0], yc + 260 * d[0]], [-260 * d[1], 260 * d[1]], color="k",
                lw=8, alpha=0.25)  # fmt: skip
        sgn = -1.0 if side == "left" else 1.0  # page direction of the wheel's outboard
        _arrow(ax, (yc, 0), (yc, 220), BLUE, "Fx", where=1.0, off=(10, 0))
        _arrow(ax, (yc, 0), (yc + sgn * 220, 0), BLUE, "Fy\n(outboard)", where=1.0,
               off=(sgn * 10 - (60 if sgn < 0 else 0), -40))  # fmt: skip
        th = np.linspace(0.2, 1.6, 30) * sgn  # from the front towards outboard
        ax.plot(yc + 120 * np.sin(th), 120 * np.cos(th), color=RED)
        ax.annotate("", xy=(yc + 120 * np.sin(th[-1]), 120 * np.cos(th[-1])),
                    xytext=(yc + 120 * np.sin(th[-3]), 120 * np.cos(th[-3])),
                    arrowprops={"arrowstyle": "->", "color": RED})  # fmt: skip
        ax.text(yc + sgn * 140, 90, "Mz toe-out", color=RED, fontsize=8,
                ha="left" if sgn > 0 else "right")  # fmt: skip
    ax.text(-half, -330, "left wheel: toe-in > 0\n(front inboard)", fontsize=8, ha="center")
    ax.text(half, -330, "right wheel: toe-in > 0", fontsize=8, ha="center")
    ax.text(0, 350, "steer angle > 0: front to the left (about +z)\n"
            "Ackermann: the inner wheel's ideal angle atan(L tan d_o / (L - t tan d_o)),\n"
            "t = track of the steering axes' ground points, L = wheelbase",
            fontsize=8, ha="center")  # fmt: skip
    ax.text(0, -450, f"loads in each wheel's own sense (the compliance matrix's): Fx "
            f"forward,\nFy outboard, Mz toe-out; wheelbase L = {L:.0f} mm (schematic)",
            fontsize=8, ha="center")  # fmt: skip
    _arrow(ax, (0, 0), (0, 200), GREY, "forward (+x)", where=1.0, off=(10, 0))
    _arrow(ax, (0, 0), (-200, 0), GREY, "+y (left)", where=1.0, off=(-40, 15))
    ax.set_xlim(-1150, 1150)
    ax.set_ylim(-540, 560)
    ax.set_aspect("equal")
    ax.set_xticks([])
    ax.set_yticks([])
    ax.set_title("Top view of the front axle (forward up)", fontsize=10)
    save_figure(fig, path, dpi=DPI, tight=True)


def write_all(out: Path) -> list[Path]:
    """Write the three pictures into ``out``; returns their paths."""
    out.mkdir(parents=True, exist_ok=True)
    paths = [out / "front_view.png", out / "side_view.png", out / "top_view.png"]
    for fn, p in zip((front_view, side_view, top_view), paths, strict=True):
        fn(p)
    return paths


if __name__ == "__main__":  # pragma: no cover - documentation build
    for p in write_all(Path(sys.argv[1] if len(sys.argv) > 1 else "docs/knc")):
        print(f"wrote {p}")
