"""The robust law's parameter vector for one configuration: the values the compiled kernel
(:mod:`fbcc_ros.core.control.robust_kernel`, which owns the vector's layout) reads each period,
computed once from the law's parameters, the insertion, the nominal pair and the period."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from fbcc_ros.core.arrays import FloatArray
from fbcc_ros.core.contact.model import PegHole
from fbcc_ros.core.control import guard as guard_mod
from fbcc_ros.core.control import identification as ident
from fbcc_ros.core.control import robust_kernel as rk
from fbcc_ros.core.control import wedge
from fbcc_ros.core.control.loop_design import design
from fbcc_ros.core.control.robust_params import DITHER_FRACTIONS, NOTCH_QUALITY, RobustParams
from fbcc_ros.core.filters import notch_coefficients, second_order_coefficients

#: How far the believed peg past the depth (the arm's depth less F_z / axial_stiffness) may fall
#: back before it counts as stopped [m], and in deviations of its noise if more.
SLIP = 2e-6
SLIP_DEVIATIONS = 10.0


def parameters(p: RobustParams, ins: Any, nom: PegHole, dt: float) -> FloatArray:
    """The kernel's parameter vector (its layout: the kernel's ``P_*`` indices) for the law's
    parameters ``p``, its insertion ``ins`` (depth, speed) and the nominal pair ``nom``, at
    period ``dt``."""
    noise = np.asarray(p.sensor_noise, dtype=float)
    # noise of the rows u = A F: offsets Fx, Fy; tilts dominated by M / R (eq. 28)
    su = np.array([noise[0], noise[1], noise[3] / nom.hole_radius,
                   noise[4] / nom.hole_radius])  # fmt: skip
    # the filter passes about w_f dt / (4 zeta) of white noise's variance
    filtered = su * math.sqrt(min(1.0, p.filter_frequency * dt / (4 * p.filter_damping)))
    base, per_depth = nom.lever_terms()
    prm = np.zeros(rk.N_PARAMS)
    chosen = design(p, dt)
    prm[rk.P_WC] = chosen.bandwidth
    prm[rk.P_DB_X : rk.P_DB_TY + 1] = p.dead_band * filtered
    prm[rk.P_FORGET] = ident.forgetting(p.identification_window, dt)
    prm[rk.P_KMIN] = p.stiffness_min
    prm[rk.P_RELEASE] = math.exp(-dt / p.release)
    prm[rk.P_DITH_F], prm[rk.P_DITH_E] = p.dither_force, p.dither_effort
    prm[rk.P_DITH_MAX_X], prm[rk.P_DITH_MAX_T] = p.dither_max_offset, p.dither_max_tilt
    prm[rk.P_U_X], prm[rk.P_U_T] = p.offset_force, p.tilt_effort
    prm[rk.P_WL], prm[rk.P_FZ_BACK] = chosen.depth_bandwidth, p.fz_back_off
    prm[rk.P_PULL] = p.pull_limit
    prm[rk.P_SINK] = 1.0 / p.axial_stiffness if p.axial_stiffness > 0.0 else 0.0
    # the believed peg's noise (F_z's over k) must not read as falling back
    prm[rk.P_SLIP] = max(SLIP, SLIP_DEVIATIONS * noise[2] * prm[rk.P_SINK])
    prm[rk.P_LEAD] = p.depth_lead + p.loop_delay  # the measured depth lags by the delay
    prm[rk.P_G_GROWTH], prm[rk.P_G_CYCLES] = p.guard_growth, p.guard_cycles
    prm[rk.P_G_AMP], prm[rk.P_G_BACKOFF], prm[rk.P_G_HOLD] = (
        p.guard_amplitude, p.guard_backoff, p.guard_hold)  # fmt: skip
    prm[rk.P_FLIM2] = p.F_ext_limit**2
    prm[rk.P_SPEED], prm[rk.P_DEPTH] = ins.speed, ins.depth
    prm[rk.P_NOISE_FZ] = noise[2]
    prm[rk.P_BASE], prm[rk.P_PER_DEPTH] = base, per_depth
    prm[rk.P_HOLE_DEPTH], prm[rk.P_HOLE_RADIUS] = nom.hole_depth, nom.hole_radius
    prm[rk.P_DT] = dt
    # the dither's phase advance per sample [rad]: a digital sinusoid whatever the step, so a
    # late sample (a step of several periods) leaves it clean and its notches exact
    prm[rk.P_F0 : rk.P_F3 + 1] = 2 * math.pi * np.array(DITHER_FRACTIONS)
    prm[rk.P_SU_X : rk.P_SU_TY + 1] = su
    prm[rk.P_MU0] = nom.friction
    prm[rk.P_COUPLING] = p.coupling_limit
    prm[rk.P_GATE] = 1.0 if p.plane_gate else 0.0
    # noise floor of each row: the filtered noise over the resolution [N/m, N/rad]
    resolution = np.array([p.offset_resolution] * 2 + [p.tilt_resolution] * 2)
    prm[rk.P_NFLOOR_X : rk.P_NFLOOR_TY + 1] = filtered / resolution
    # a half-wave counts above guard_amplitude deviations or guard_effort of the row's hold,
    # whichever is lower (a tilt row's 40 deviations are over its hold: the depth loop would
    # back off on an oscillation before the guard saw it), never under GUARD_NOISE_PEAKS
    hold = np.array([p.offset_force] * 2 + [p.tilt_effort] * 2)
    prm[rk.P_G_MIN_X : rk.P_G_MIN_TY + 1] = np.maximum(
        np.minimum(p.guard_amplitude * filtered, p.guard_effort * hold),
        guard_mod.NOISE_PEAKS * filtered)  # fmt: skip
    prm[rk.P_LEAD_X], prm[rk.P_LEAD_T] = p.lateral_lead, p.tilt_lead
    prm[rk.P_TILT_DEPTH] = p.tilt_depth
    # fade of the dither: a first-order lag of one period of the slowest dither
    prm[rk.P_DITH_FADE] = 1.0 - math.exp(-min(DITHER_FRACTIONS))
    for j in range(4):
        prm[rk.P_NOTCH + 3 * j : rk.P_NOTCH + 3 * j + 3] = notch_coefficients(
            prm[rk.P_F0 + j] / dt, NOTCH_QUALITY, dt)  # fmt: skip
    prm[rk.P_SETTLE] = p.settle_force
    prm[rk.P_SETTLE_GAIN] = p.settle_gain
    prm[rk.P_TILT_RATE] = p.tilt_rate
    prm[rk.P_FRICTION_MAX] = p.friction_max
    prm[rk.P_ENTRY_STEP], prm[rk.P_ENTRY_DEPTH] = p.entry_step, p.entry_depth
    prm[rk.P_SEARCH_SPEED] = p.search_speed
    # an interference fit's peg is wider than its bore: it always meets the rim, and only a
    # chamfer leads it in (hole_search); it is held all round, so it neither wedges nor has a
    # side free to turn into
    clearance = nom.hole_radius > nom.peg_radius
    prm[rk.P_SEARCH_RANGE] = p.search_range if clearance else 0.0
    prm[rk.P_SEARCH_FORCE] = p.search_force
    prm[rk.P_WEDGE_FORCE] = p.wedge_force if clearance else 0.0
    prm[rk.P_BORE_GAIN] = p.bore_gain if clearance else 1.0
    prm[rk.P_PUSH] = p.push_limit if clearance else 0.0
    prm[rk.P_WEDGE_DEPTHS : rk.P_WEDGE_DEPTHS + 2] = wedge.depths(
        nom.hole_radius, nom.peg_radius, nom.chamfer)  # fmt: skip
    prm[rk.P_LEAN_ARM] = nom.peg_length if nom.acting_point == "peg_top" else 0.0
    prm[rk.P_DEPTH_F : rk.P_DEPTH_F + 6] = second_order_coefficients(
        p.depth_filter_frequency, p.filter_damping, dt)  # fmt: skip
    # the depth loop's effort is a row above its noise through that faster filter, as the
    # lateral loops' dead band: noise alone (a virtual sensor's) must not hold the depth
    passed = math.sqrt(min(1.0, p.depth_filter_frequency * dt / (4 * p.filter_damping)))
    prm[rk.P_DNOISE : rk.P_DNOISE + 4] = p.dead_band * su * passed
    return prm
