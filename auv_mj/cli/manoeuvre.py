"""`auv-mj manoeuvre`: a scripted zig-zag manoeuvre in a channel (`auv_mj.sim.manoeuvre`); prints the track."""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

from auv_mj.arenas.arena import load
from auv_mj.cli.options import bounded_float
from auv_mj.sim.manoeuvre import (
    APPROACH_TIME,
    CHANNEL_HALF_WIDTH,
    SURGE_FORCE,
    YAW_MOMENT,
    ZIGZAG_ANGLE,
    channel_arena,
    zigzag,
)
from auv_mj.sim.vehicle import vehicle_facts

MAX_DURATION = 3600.0
"""Longest simulated manoeuvre [s]."""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of `auv-mj manoeuvre`."""
    limits = vehicle_facts()
    parser.add_argument("--duration", type=bounded_float(0.0, MAX_DURATION, "s", low_open=True), default=60.0,
                        help="simulated time [s] (default 60)")
    parser.add_argument("--angle", type=bounded_float(0.0, 89.0, "deg", low_open=True), default=ZIGZAG_ANGLE,
                        help=f"heading switch angle [deg] (default {ZIGZAG_ANGLE:g}: a 20/20 zig-zag)")
    parser.add_argument("--tau-u", type=bounded_float(-limits.surge_limit, limits.surge_limit, "N"),
                        default=SURGE_FORCE,
                        help=f"surge force [N] (default {SURGE_FORCE:g})")
    parser.add_argument("--tau-r", type=bounded_float(-limits.yaw_limit, limits.yaw_limit, "N m"), default=YAW_MOMENT,
                        help=f"bang-bang yaw moment [N m] (default {YAW_MOMENT:g})")
    parser.add_argument("--approach", type=bounded_float(0.0, MAX_DURATION, "s"), default=APPROACH_TIME,
                        help=f"straight run before the first switch [s] (default {APPROACH_TIME:g})")
    parser.add_argument("--print-every", type=bounded_float(0.0, MAX_DURATION, "s", low_open=True), default=2.0,
                        help="track print interval [s] (default 2)")
    parser.add_argument("--half-width", type=bounded_float(1.0, 1000.0, "m", low_open=True), default=CHANNEL_HALF_WIDTH,
                        help=f"channel half width [m] (default {CHANNEL_HALF_WIDTH:g})")


def run(args: argparse.Namespace) -> int:
    """`auv-mj manoeuvre`: runs the zig-zag and prints the track, the sonar and the zig-zag figures."""
    wall_clock = time.perf_counter()
    physics = load(channel_arena(args.half_width))
    result = zigzag(physics, args.duration, args.angle, args.tau_u, args.tau_r, args.approach)
    elapsed = time.perf_counter() - wall_clock

    print(f"{args.angle:g}/{args.angle:g} zig-zag: tau_u = {args.tau_u:g} N, tau_r = +-{args.tau_r:g} N m "
          f"after {args.approach:g} s, channel walls at y = +-{args.half_width:g} m, "
          f"dt = {physics.timestep():g} s")
    print(f"{'t [s]':>7} {'x [m]':>8} {'y [m]':>7} {'psi [deg]':>9} {'u [m/s]':>8} {'v [m/s]':>8} "
          f"{'r [deg/s]':>9} {'tau_r':>6}   sonar S1..S9 [m] (120 = no echo)")
    every = max(1, int(round(args.print_every / physics.timestep())))
    sonar_times = result.sonar[:, 0]
    for row in result.track[every - 1::every]:
        t, x, y, psi, u, v, r, tau_r = row
        ranges = result.sonar[np.searchsorted(sonar_times, t + 1e-9) - 1, 1:]
        print(f"{t:7.1f} {x:8.2f} {y:7.2f} {math.degrees(psi):9.2f} {u:8.3f} {v:8.3f} {math.degrees(r):9.2f} "
              f"{tau_r:6.1f}   " + " ".join(f"{d:5.1f}" for d in ranges))
    overshoots = ", ".join(f"{o:.1f}" for o in result.overshoots) or "none"
    print(f"switches at t = {', '.join(f'{t:.1f}' for t in result.switch_times)} s")
    print(f"overshoot angles [deg]: {overshoots}; period {result.period:.1f} s")
    print(f"closest wall by sonar: {result.sonar[:, 1:].min():.2f} m; "
          f"{args.duration:g} s simulated in {elapsed:.2f} s wall clock")
    return 0
