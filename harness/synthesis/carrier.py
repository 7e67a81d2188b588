"""``synth carrier``: seed 004's carrier (cam) law for a uniform bed speed in the printing zone and for the
bed's harmonic return, its invariants B, C1, C3 on both strokes, and the disc-cam geometry for the seed's
maximum pressure angle (with the roller that makes the seed's r0/S hold for the working profile).

    synth carrier [--zone START END] [--stroke M] [--runup U] [--pressure DEG] [--arm M] [--no-cam] [--json]

The equations live in fmus.physics.bed_law; this module parses and prints.
"""
from __future__ import annotations

import json
import math

from harness.synthesis import fail, summary, typed


def register(subparsers):
    p = subparsers.add_parser("carrier", help="seed 004: carrier law for a uniform bed, invariants, cam geometry",
                              description=summary(__doc__))
    p.add_argument("--zone", type=float, nargs=2, default=(0.08, 0.24), metavar=("START", "END"),
                   help="printing zone, bed positions from the stroke start [m] (default: bed_drive's 0.08 0.24)")
    p.add_argument("--stroke", type=float, default=None,
                   help="bed stroke [m] (default: R6 * alpha_Sigma with bed_drive's R6 = 0.05 m)")
    p.add_argument("--runup", type=float, default=None,
                   help="bed run-up share of the working stroke (default: the largest that covers the zone)")
    p.add_argument("--pressure", type=float, default=28.0, help="largest cam pressure angle [deg] (seed: 28)")
    p.add_argument("--arm", type=float, default=0.1, help="follower arm [m] (scale of the cam; default 0.1)")
    p.add_argument("--no-cam", action="store_true", help="skip the cam geometry search (about 15 s)")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=run)
    return p


def _bad_input(args, stroke: float) -> str:
    """What is wrong with the options, in the words and units they were typed in ('' if nothing): the
    synthesis itself works on shares of the stroke, which the user never typed."""
    if not (math.isfinite(stroke) and stroke > 0.0):
        return f"{typed('stroke', stroke, 'm')} must be > 0"
    start, end = args.zone
    if not 0.0 < start < end < stroke:
        return (f"--zone {start:g} {end:g} m: the printing zone must lie inside the stroke, 0 < START < END < "
                f"{stroke:.4g} m" + ("" if args.stroke is not None else " (bed_drive's stroke; see --stroke)"))
    if args.runup is not None and not 0.0 < args.runup < 0.5:
        return f"{typed('runup', args.runup)} must lie in (0, 0.5): a share of the working stroke at each end"
    if not 0.0 < args.pressure < 90.0:
        return f"{typed('pressure', args.pressure, 'deg')} must lie in (0, 90)"
    if not args.arm > 0.0:
        return f"{typed('arm', args.arm, 'm')} must be > 0"
    return ""


def run(args) -> int:
    import numpy as np

    from fmus.physics import bed_cam, bed_law as B
    from fmus.physics.motion_law import Law

    st = B.working_stroke()
    K = B.SEED_RATIO
    alpha_S = K * abs(st.swing) + (1 + K) * B.SEED_CARRIER_SWING
    stroke = args.stroke if args.stroke is not None else 0.05 * alpha_S
    bad = _bad_input(args, stroke)
    if bad:
        return fail("carrier", bad)
    try:
        u = args.runup if args.runup is not None else B.runup_for_zone(args.zone[0] / stroke,
                                                                         args.zone[1] / stroke)
        cl = B.carrier_law(u)
        k = np.linspace(0.0, 1.0, 20001)
        _, bg, _ = cl.law(k)
        _, bd, _ = st.invariants(k)
        bed_b = (K * abs(st.swing) * bd + (1 + K) * cl.gamma_swing * bg) / cl.alpha_swing
        zone = (k >= u) & (k <= 1 - u)
        data = {"runup": u, "alpha_swing_deg": math.degrees(cl.alpha_swing),
                "delta_swing_deg": math.degrees(cl.delta_swing), "bed_stroke_m": stroke,
                "zone_shares": [args.zone[0] / stroke, args.zone[1] / stroke],
                "uniform_shares": [float(B.bed_invariants(u, u, math)[0]),
                                   float(B.bed_invariants(1 - u, u, math)[0])],
                "bed_b_zone_min": float(bed_b[zone].min()), "bed_b_zone_max": float(bed_b[zone].max()),
                "carrier_working": B.stroke_invariants(cl.law),
                "carrier_idle": B.stroke_invariants(B.carrier_return_law()),
                "branch": st.branch,
                "equal_peak_runup": B.equal_peak_runup(cl.phase / (2 * math.pi)),
                "bed_working": B.stroke_invariants(Law("bed", "", ((1.0, lambda x, m: B.bed_invariants(x, u, m)),)))}
        if not args.no_cam:
            d = bed_cam.design_cam(u, math.radians(args.pressure), args.arm)
            rc = bed_cam.pitch_curvature_min(u, d.cam_distance, d.follower_arm, d.base_radius)
            data["cam"] = {"follower_arm_m": d.follower_arm, "cam_distance_m": d.cam_distance,
                           "pitch_curvature_min_m": rc, "r_min_over_S": rc / (d.follower_arm * B.SEED_CARRIER_SWING),
                           "base_radius_m": d.base_radius, "r0_over_S": d.r0_over_S,
                           "pressure_max_deg": math.degrees(d.pressure_max),
                           "roller_radius_m": d.roller_radius,
                           "profile_r_min_over_S": (rc - d.roller_radius) / (d.follower_arm * B.SEED_CARRIER_SWING),
                           "best_pressure_at_r0_S_0.95_deg": math.degrees(d.best_at_seed_ratio)}
    except ValueError as e:
        return fail("carrier", str(e))
    if args.json:
        print(json.dumps(data))
        return 0
    cw, ci, bw = data["carrier_working"], data["carrier_idle"], data["bed_working"]
    print(f"seed 004 carrier law for a uniform bed (four-bar 1 : 1.91579 : 2.10526 : 2.25263, z3/z5 = {K:g}, "
          f"branch {st.branch:+d}, carrier swing 40 deg, rise phase = the four-bar's working stroke "
          f"{math.degrees(cl.phase):.4f} deg)")
    print(f"  bed swing alpha_S = 3 delta_S + 4 gamma_S       {data['alpha_swing_deg']:.4f} deg "
          f"(delta_S = {data['delta_swing_deg']:.4f} deg), stroke {stroke:.4f} m")
    print(f"  printing zone (share of the stroke)             {data['zone_shares'][0]:.4f} - {data['zone_shares'][1]:.4f}")
    print(f"  bed run-up share u (largest covering the zone)  {u:.6f}  -> uniform from "
          f"{data['uniform_shares'][0]:.4f} to {data['uniform_shares'][1]:.4f} of the stroke")
    print(f"  bed velocity invariant in the uniform segment   {data['bed_b_zone_min']:.12f} - {data['bed_b_zone_max']:.12f}")
    print(f"  (the run-up share with equal acceleration peaks over the whole cycle, working and idle, would be "
          f"{data['equal_peak_runup']:.4f})")
    print("  invariants (Tir; each stroke by its own duration and swing): B = peak of b = da/dk,")
    print("  C1 = peak |c| = |d2a/dk2| before the velocity peak (run-up), C3 = after it (run-out)")
    for name, v in (("carrier, working stroke (synthesised)", cw), ("carrier, idle stroke (bed returns by K0)", ci),
                    ("bed, working stroke (target law)", bw)):
        print(f"  {name:<40s} B = {v['B']:.4f}  C1 = {v['C1']:.4f}  C3 = {v['C3']:.4f}")
    if "cam" in data:
        c = data["cam"]
        print(f"  disc cam for a largest pressure angle of {args.pressure:g} deg (CamRocker mechanism 1):")
        print(f"    with the seed's r0/S = 0.95 (S = arm * swing) the best centre distance gives "
              f"{c['best_pressure_at_r0_S_0.95_deg']:.2f} deg")
        print(f"    arm {c['follower_arm_m']:.4f} m, centre distance {c['cam_distance_m']:.4f} m, base radius "
              f"{c['base_radius_m']:.4f} m (r0/S = {c['r0_over_S']:.4f}): {c['pressure_max_deg']:.2f} deg")
        print(f"    smallest radius of curvature of its pitch curve {c['pitch_curvature_min_m']:.4f} m "
              f"(r_min/S = {c['r_min_over_S']:.4f}; > 0: convex)")
        print(f"    the seed's r0/S = 0.95 read for the working profile: roller radius {c['roller_radius_m']:.4f} m; "
              f"the profile's r_min/S = {c['profile_r_min_over_S']:.4f}")
    return 0
