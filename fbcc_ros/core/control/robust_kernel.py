"""The compiled per-period step of the robust law (:mod:`fbcc_ros.core.control.robust` is the law
and its doc): the layout of its per-trial state and of its parameter vector (whose values for a
configuration :mod:`fbcc_ros.core.control.robust_vector` computes), and the kernel that steps
every trial (row) in place."""

from __future__ import annotations

import math

import numba
import numpy as np

from fbcc_ros.core.arrays import FloatArray
from fbcc_ros.core.contact.segmentation import direct_row, lever_at, tilt_terms
from fbcc_ros.core.control import guard as guard_mod
from fbcc_ros.core.control import hole_search as search
from fbcc_ros.core.control import identification as ident
from fbcc_ros.core.control import press_fit, wedge
from fbcc_ros.core.filters import notch_step, second_order_row, second_order_step

#: Per row j (dx, dy, theta_x, theta_y): the other row of its plane (identification.PLANES).
PARTNER = tuple(sum(plane) - j for j in range(4) for plane in ident.PLANES if j in plane)

# Columns of the per-trial state of the robust kernel (besides the identifier's and guard's).
C_X = 0  # filtered rows ū (5, depth unused)
C_V = 5  # their rates
C_INT = 10  # integrators ∫ x_d dt (5; depth unused)
C_RFR = 15  # the reference x_rfr (the features at the start)
C_PREV_X = 20  # measured features of the previous sample
C_PREV_U = 25  # direction rows of the previous sample
C_LCMD = 30  # depth command
C_T = 31  # time since the start [s]
C_HOLD = 32  # time until which the depth holds (guard) [s]
C_MU = 33  # friction estimate
C_CONTACT = 34  # 1 when the last sample was contact
C_HAVE_PREV = 35  # 1 once a previous sample exists
C_BACKOFF = 36  # gain back-off factors of the 4 rows (>= 1)
C_TRIPS = 40  # guard trips so far
C_STOPPED = 41  # 1 once the force limit stopped the insertion
C_ELAPSED = 42  # insertion time while not stopped
C_DITHER = 43  # dither amplitudes of the 4 rows, as faded in and out
C_REACHED = 47  # 1 once the depth command has reached the depth
C_NOTCH = 48  # the guard's notches: each row's 2 at its plane's dither frequencies (2 each)
C_DEPTH_F = 64  # the depth loop's low-pass of each row (x, v)
C_DNOTCH = 72  # the depth loop's notches, as C_NOTCH
C_SAMPLES = 88  # samples since the start (the dither's phase)
C_LEVER = 89  # the lever's friction (identification.N_LEVER columns; 0: the scenario's μ)
C_SEARCHED = C_LEVER + ident.N_LEVER  # the hole search's travel so far [m] (hole_search)
C_WEDGE = C_SEARCHED + 1  # a wedge's state (wedge.N_STATE columns)
C_SINK = C_WEDGE + wedge.N_STATE  # how far the grip held the peg above the arm [m] (P_SINK)
C_PEG = C_SINK + 1  # the deepest the peg was believed past the depth (arm's depth - C_SINK) [m]
C_PRESS = C_PEG + 1  # the push bound's press line (press_fit.N_STATE columns)
N_MAIN = C_PRESS + press_fit.N_STATE

# Indices into the parameter vector of the kernel.
(P_WC, P_DB_X, P_DB_Y, P_DB_TX, P_DB_TY, P_FORGET, P_KMIN, P_RELEASE, P_DITH_F,
 P_DITH_E, P_DITH_MAX_X, P_DITH_MAX_T, P_U_X, P_U_T, P_WL, P_LEAD, P_FZ_BACK,
 P_G_GROWTH, P_G_CYCLES, P_G_AMP, P_G_BACKOFF, P_G_HOLD, P_FLIM2, P_SPEED, P_DEPTH,
 P_NOISE_FZ, P_BASE, P_PER_DEPTH, P_HOLE_DEPTH, P_HOLE_RADIUS, P_DT, P_F0, P_F1, P_F2,
 P_F3, P_SU_X, P_SU_Y, P_SU_TX, P_SU_TY, P_MU0, P_COUPLING, P_GATE, P_NFLOOR_X,
 P_NFLOOR_Y, P_NFLOOR_TX, P_NFLOOR_TY, P_G_MIN_X, P_G_MIN_Y, P_G_MIN_TX,
 P_G_MIN_TY, P_LEAD_X, P_LEAD_T, P_TILT_DEPTH, P_DITH_FADE, P_NOTCH) = range(55)  # fmt: skip
P_NOTCH_END = P_NOTCH + 12  # (b0, b1, a2) of the notch at each row's dither frequency
P_SETTLE = P_NOTCH_END  # the band of every row once the depth is reached
P_DEPTH_F = P_NOTCH_END + 1  # the depth loop's low-pass (filters.second_order_coefficients)
P_DNOISE = P_DEPTH_F + 6  # what the depth loop discounts of each row: its noise there (4)
P_SETTLE_GAIN = P_DNOISE + 4  # the lateral loops' gain once the depth is reached (of ω_c)
P_TILT_RATE = P_SETTLE_GAIN + 1  # the fastest a tilt row turns the peg [rad/s]
P_FRICTION_MAX = P_TILT_RATE + 1  # the largest friction the lever may take (0: off)
P_ENTRY_STEP = P_FRICTION_MAX + 1  # the depth step a period allows through the entry [m]
P_ENTRY_DEPTH = P_ENTRY_STEP + 1  # the entry's depth [m]
P_SEARCH_SPEED = P_ENTRY_DEPTH + 1  # the hole search's speed [m/s] (hole_search)
P_SEARCH_RANGE = P_SEARCH_SPEED + 1  # its travel [m] (0: off)
P_SEARCH_FORCE = P_SEARCH_RANGE + 1  # the axial force it holds [N]
P_LEAN_ARM = P_SEARCH_FORCE + 1  # the acting point's height over the tip if on the peg [m]
P_WEDGE_FORCE = P_LEAN_ARM + 1  # the axial force of a wedged clearance fit [N] (0: none)
P_WEDGE_DEPTHS = P_WEDGE_FORCE + 1  # the depths between which it can wedge (2) [m]
P_BORE_GAIN = P_WEDGE_DEPTHS + 2  # the tilt loops' gain in a clearance fit's bore (of ω_c)
P_PULL = P_BORE_GAIN + 1  # the most the depth loop pulls on the peg [N] (0: no bound)
P_PUSH = P_PULL + 1  # the most it pushes in a clearance fit's bore [N] (0: no bound)
P_SINK = P_PUSH + 1  # the grip's axial compliance [m/N] (0: rigid; robust_params.axial_stiffness)
P_SLIP = P_SINK + 1  # how far the believed peg may fall back before it counts as stopped [m]
N_PARAMS = P_SLIP + 1


@numba.njit(cache=True)  # type: ignore[misc]
def without_dither(prm: FloatArray, bank: FloatArray, j: int, value: float) -> float:
    """Row j's value past the notches at its plane's two dither frequencies (module doc,
    excitation); advances their state in ``bank`` (16 columns: 4 per row)."""
    for n, row in enumerate((j, PARTNER[j])):  # its own dither's, then its plane partner's
        value = notch_step(prm[P_NOTCH + 3 * row : P_NOTCH + 3 * row + 3],
                           bank[4 * j + 2 * n : 4 * j + 2 * n + 2], value)  # fmt: skip
    return value  # type: ignore[no-any-return]


@numba.njit(cache=True)  # type: ignore[misc]
def robust_rows(
    w: FloatArray,
    x: FloatArray,
    prm: FloatArray,
    c: FloatArray,
    main: FloatArray,
    idn: FloatArray,
    grd: FloatArray,
    command: FloatArray,
) -> None:
    """One control period of every trial (row); state arrays advanced in place."""
    dt = prm[P_DT]
    u = np.zeros(5)
    d_rows = np.zeros(4)
    d_u = np.zeros(4)
    floor = np.zeros(4)
    backoff = np.ones(4)
    excess = np.zeros(4)
    jac = np.zeros(4)
    k_row = np.zeros(4)
    for i in range(w.shape[0]):
        m = main[i]
        # Algorithm 1 runs while |F_ext| <= F_ext_limit; past it the insertion stops for good.
        if w[i, 0] * w[i, 0] + w[i, 1] * w[i, 1] + w[i, 2] * w[i, 2] > prm[P_FLIM2]:
            m[C_STOPPED] = 1.0
        depth = max(x[i, 2], 0.0)
        # eq. 24's lever with the part's friction once known: base + (μ - μ_nominal) R
        mu_part = ident.lever_friction(m[C_LEVER : C_LEVER + ident.N_LEVER], prm[P_MU0])
        base = prm[P_BASE] + (mu_part - prm[P_MU0]) * prm[P_HOLE_RADIUS]
        direct_row(w[i], depth, base, prm[P_PER_DEPTH], prm[P_HOLE_DEPTH],
                   prm[P_HOLE_RADIUS], u)  # u = A(l) F, eq. (28)  # fmt: skip
        u[2] = 0.0  # the depth is not filtered: it has its own loop
        # contact: Fz or a row above its noise
        contact = w[i, 2] > 3.0 * prm[P_NOISE_FZ]
        for j in range(4):
            contact = contact or abs(u[ident.ROWS[j]]) > 4.0 * prm[P_SU_X + j]
        m[C_CONTACT] = 1.0 if contact else 0.0
        # identification of each row's stiffness from the increments
        for j in range(4):
            f = ident.ROWS[j]
            d_rows[j] = x[i, f] - m[C_PREV_X + f]
            d_u[j] = u[f] - m[C_PREV_U + f]
            backoff[j] = m[C_BACKOFF + j]
        ident.floor_row(depth, prm[P_KMIN], floor)
        for j in range(4):  # the noise floor: no gain that noise alone could drive further
            floor[j] = max(floor[j], prm[P_NFLOOR_X + j])
        if m[C_LCMD] >= prm[P_DEPTH] + m[C_SINK]:
            m[C_REACHED] = 1.0
        # at the depth nothing excites the fit: it may raise the estimate, not release it
        release = prm[P_RELEASE] if m[C_REACHED] == 0.0 else 1.0
        identify = contact and m[C_HAVE_PREV] > 0.0
        d_depth = x[i, 2] - m[C_PREV_X + 2]
        ident.identify_planes(idn[i], d_rows, d_depth, d_u, identify,
                              prm[P_FORGET], floor, release, backoff)  # fmt: skip
        # the lever's friction from samples sliding in on one contact (identification doc)
        f_lat = math.sqrt(w[i, 0] * w[i, 0] + w[i, 1] * w[i, 1])
        sample = -1.0
        if (identify and prm[P_FRICTION_MAX] > 0.0 and depth >= ident.LEVER_MIN_DEPTH
                and d_depth >= ident.LEVER_SLIDE * prm[P_SPEED] * dt
                and f_lat > max(5.0 * prm[P_SU_X], ident.LEVER_MIN_FORCE)):
            # the nominal lever less its friction arm: the engaged wall's mean height
            wall = (lever_at(depth, prm[P_BASE], prm[P_PER_DEPTH], prm[P_HOLE_DEPTH])
                    - prm[P_MU0] * prm[P_HOLE_RADIUS])
            sample = ident.one_contact_friction(w[i], depth, wall, prm[P_HOLE_RADIUS])
        ident.lever_friction_update(m[C_LEVER : C_LEVER + ident.N_LEVER], sample, dt,
                                    prm[P_FRICTION_MAX])  # fmt: skip
        for f in range(5):
            m[C_PREV_X + f] = x[i, f]
            m[C_PREV_U + f] = u[f]
        m[C_HAVE_PREV] = 1.0
        m[C_MU] = ident.friction_update(m[C_MU], w[i, 2], f_lat, 5.0 * prm[P_SU_X], dt)
        # H_f: the filtered rows ū (eq. 27 with unit DC gain)
        xf = m[C_X : C_X + 5]
        vf = m[C_V : C_V + 5]
        second_order_row(c, xf, vf, u)
        # the hole search: the peg on the top face beside the bore (hole_search)
        searching = False
        started = m[C_SEARCHED] > 0.0
        if (m[C_STOPPED] == 0.0 and m[C_REACHED] == 0.0 and m[C_SEARCHED] < prm[P_SEARCH_RANGE]
                and search.within_reach(depth, prm[P_TILT_DEPTH], started)):
            _, cg_r = tilt_terms(lever_at(depth, base, prm[P_PER_DEPTH], prm[P_HOLE_DEPTH]),
                                 prm[P_HOLE_RADIUS])  # fmt: skip
            sx, sy = search.face_support(w[i, 2], xf[3], xf[4], cg_r, prm[P_LEAN_ARM],
                                         math.tan(x[i, 4]), math.tan(x[i, 3]))
            support = math.hypot(sx, sy)
            searching = search.on_face(w[i, 2], f_lat, support,
                                       max(prm[P_DB_TX], prm[P_DB_TY]), prm[P_SEARCH_FORCE],
                                       started)
            if searching:
                step = prm[P_SEARCH_SPEED] * dt
                m[C_INT] += step * sx / support  # the command moves away from the support
                m[C_INT + 1] += step * sy / support
                m[C_SEARCHED] += step
        # oscillation guard on each filtered row: a trip backs that row's gain off, holds depth
        effort = 0.0
        j_max = 0
        for j in range(4):
            f = ident.ROWS[j]
            scale = prm[P_U_X] if j < 2 else prm[P_U_T]
            quiet = without_dither(prm, m[C_NOTCH : C_NOTCH + 16], j, xf[f])
            # what the depth loop sees: the row through its own, faster low-pass (module doc)
            fast = second_order_step(prm[P_DEPTH_F : P_DEPTH_F + 6],
                                     m[C_DEPTH_F + 2 * j : C_DEPTH_F + 2 * j + 2], u[f])
            fast = without_dither(prm, m[C_DNOTCH : C_DNOTCH + 16], j, fast)  # fmt: skip
            if guard_mod.guard_step(grd[i, j], quiet, prm[P_G_GROWTH], int(prm[P_G_CYCLES]),
                                    prm[P_G_MIN_X + j]):  # fmt: skip
                m[C_BACKOFF + j] *= prm[P_G_BACKOFF]
                ident.back_off(idn[i], j, prm[P_G_BACKOFF])
                m[C_TRIPS] += 1.0
                m[C_HOLD] = m[C_T] + prm[P_G_HOLD]
            above = max(abs(fast) - prm[P_DNOISE + j], 0.0) / scale
            if above > effort:
                effort, j_max = above, j
        running = m[C_STOPPED] == 0.0
        m[C_T] += dt
        m[C_SAMPLES] += 1.0
        if running:
            m[C_ELAPSED] += dt
        if not running:
            continue  # the command is held
        # scheduled integrators, per plane: x_c = x_rfr - ∫ ω_c Ĵ⁻¹ dz(ū) dt
        for j in range(4):
            f = ident.ROWS[j]
            band = prm[P_DB_X + j]
            if m[C_REACHED] > 0.0:  # at the depth only a settle_force moves the peg
                band = max(band, prm[P_SETTLE])
            excess[j] = max(abs(xf[f]) - band, 0.0)
            if xf[f] < 0.0:
                excess[j] = -excess[j]
        # in a clearance fit's bore a peg in two-point contact goes in only as fast as the tilt
        # loops turn it upright: they run at bore_gain ω_c (robust_params.bore_gain)
        boost = 1.0
        if m[C_REACHED] == 0.0 and depth >= prm[P_ENTRY_DEPTH]:
            boost = prm[P_BORE_GAIN]
        held = False  # a tilt row's slope is the coupling's: the part is held all round
        for plane in range(2):
            r_d, r_t = ident.PLANES[plane]
            coupling = ident.used_matrix(idn[i, plane], plane, prm[P_COUPLING], jac)
            # k_θ >= boost² |∂u_d/∂θ| U_θ / U_d: a tilt step then moves the offset row's effort
            # no faster than ω_c / boost times the tilt's own (module doc, coupled tilt row)
            floor_t = boost * boost * abs(coupling) * prm[P_U_T] / prm[P_U_X]
            held = held or floor_t > jac[3]
            jac[3] = max(jac[3], floor_t)
            k_row[r_d], k_row[r_t] = jac[0], jac[3]
            if prm[P_GATE] > 0.0:
                # plane gate: a plane whose rows are both inside the dead band is not in
                # contact (nothing to sense, Remark 2) and holds; one that is integrates both
                # rows whole, so a weak row is not eaten by its dead band
                if excess[r_d] == 0.0 and excess[r_t] == 0.0:
                    continue
                excess[r_d], excess[r_t] = xf[ident.ROWS[r_d]], xf[ident.ROWS[r_t]]
            det = jac[0] * jac[3] - jac[1] * jac[2]
            v_d = (jac[3] * excess[r_d] - jac[1] * excess[r_t]) / det
            v_t = (jac[0] * excess[r_t] - jac[2] * excess[r_d]) / det
            # at the depth the fit is no longer excited while the tilt's stiffness still
            # rises (as l³): the tilt loops settle at a fraction of ω_c, inside the gain margin
            wc = prm[P_WC]
            wc_t = prm[P_SETTLE_GAIN] * wc if m[C_REACHED] > 0.0 else boost * wc
            if not searching:  # on the face its friction is not an offset
                m[C_INT + ident.ROWS[r_d]] += wc * v_d * dt
            if depth >= prm[P_TILT_DEPTH]:  # at the entry a tilt row cannot tell tilt
                # no faster than tilt_rate: a faster turn passes zero before it is seen
                turn = prm[P_TILT_RATE] * dt
                m[C_INT + ident.ROWS[r_t]] += min(max(wc_t * v_t * dt, -turn), turn)
        # a wedged clearance fit turns its tilt to free itself (wedge)
        stuck = False
        if prm[P_WEDGE_FORCE] > 0.0:
            wdg = m[C_WEDGE : C_WEDGE + wedge.N_STATE]
            free = not searching and m[C_REACHED] == 0.0
            stuck = free and wedge.wedged(wdg, depth, w[i, 2], effort < wedge.QUIET,
                                          prm[P_WEDGE_FORCE], dt, prm[P_WEDGE_DEPTHS],
                                          prm[P_WEDGE_DEPTHS + 1])  # fmt: skip
            if stuck:
                tx, ty = wedge.probe_step(wdg, dt, prm[P_TILT_RATE], xf[3], xf[4],
                                          prm[P_WEDGE_FORCE])
                m[C_INT + 3] -= tx  # the command moves by (tx, ty)
                m[C_INT + 4] -= ty
        for j in range(4):
            f = ident.ROWS[j]
            k_used = k_row[j]
            amp = 0.0
            if contact and m[C_LCMD] < prm[P_DEPTH] + m[C_SINK]:  # while inserting: sized, capped
                cap = prm[P_DITH_MAX_X] if j < 2 else prm[P_DITH_MAX_T]
                size = prm[P_DITH_F] if j < 2 else prm[P_DITH_E]
                amp = min(size / k_used, cap)
            # faded in and out over about a dither period: switched at an arbitrary phase, it
            # would step the command by up to its amplitude (a tight stiff fit at the depth)
            m[C_DITHER + j] += prm[P_DITH_FADE] * (amp - m[C_DITHER + j])
            dither = m[C_DITHER + j] * math.sin(prm[P_F0 + j] * m[C_SAMPLES])
            # the command leads the measured pose by at most the lateral lead: what a contact
            # of unknown stiffness may be pushed before its force is seen (loop_delay later)
            lead = prm[P_LEAD_X] if j < 2 else prm[P_LEAD_T]
            target = m[C_RFR + f] - m[C_INT + f]
            if target > x[i, f] + lead:
                m[C_INT + f] = m[C_RFR + f] - (x[i, f] + lead)
            elif target < x[i, f] - lead:
                m[C_INT + f] = m[C_RFR + f] - (x[i, f] - lead)
            command[i, f] = m[C_RFR + f] - m[C_INT + f] + dither
        # depth: hold the lateral effort at 1 with the depth loop (module doc)
        v = prm[P_SPEED]
        rate = v
        if contact:
            scale = prm[P_U_X] if j_max < 2 else prm[P_U_T]
            slope = abs(ident.plane_depth_gain(idn[i], j_max)) / scale  # ∂e/∂l [1/m]
            rate = prm[P_WL] * (1.0 - effort) / max(slope, 1e-9)
            rate = min(max(rate, -v), v)
        if depth < prm[P_ENTRY_DEPTH]:  # through the rim: one step a sample, whatever the rate
            rate = min(rate, prm[P_ENTRY_STEP] / prm[P_DT])
        if m[C_REACHED] > 0.0 and prm[P_SINK] > 0.0:
            # at the depth with the grip's compression told (axial_stiffness) the fit holds the
            # peg, on the hole's bottom maybe: the arm moves one step a sample either way (100
            # Hz: a fifth of the insertion's), and does not pull it (it backs off to the depth)
            step = prm[P_ENTRY_STEP] / prm[P_DT]
            rate = min(max(rate, -step, min(prm[P_DEPTH] - m[C_LCMD], 0.0) / dt), step)
        if searching:
            rate = min(rate, search.force_rate(w[i, 2], prm[P_SEARCH_FORCE], prm[P_WL]))
        if prm[P_PUSH] > 0.0:  # push_limit, or a press fit's line (press_fit)
            push = press_fit.bound(m[C_PRESS : C_PRESS + press_fit.N_STATE], depth, w[i, 2],
                                   prm[P_PUSH], dt)  # fmt: skip
            if depth >= prm[P_ENTRY_DEPTH] and not held:
                rate = min(rate, search.force_rate(w[i, 2], push, prm[P_WL]))
        if stuck:  # a light push while the probe turns the peg (wedge)
            rate = min(max(search.hold_rate(w[i, 2], prm[P_SEARCH_FORCE], prm[P_WL]), -v), v)
        if m[C_T] < m[C_HOLD]:
            rate = min(rate, 0.0)
        if w[i, 2] > prm[P_FZ_BACK]:
            rate = -v
        elif prm[P_PULL] > 0.0 and w[i, 2] < -prm[P_PULL]:  # robust_params.pull_limit
            rate = max(rate, 0.0)
        # the arm's depth is the peg's plus the grip's axial compression F_z / k: the arm goes
        # that much deeper (robust_params.axial_stiffness) and, once there, holds; backed off,
        # it does not push in again (its fit holds the peg, maybe on the hole's bottom)
        compressed = max(w[i, 2], 0.0) * prm[P_SINK]
        sink = compressed
        if m[C_REACHED] > 0.0:
            sink = min(m[C_SINK], max(m[C_LCMD] - prm[P_DEPTH], 0.0))
        elif prm[P_SINK] > 0.0 and m[C_LCMD] >= prm[P_DEPTH]:
            # past the arm's depth F_z falling (the arm behind its command) must not pull the
            # command back: the arm would pull the peg out and push it back in
            sink = max(sink, m[C_SINK])
            # the believed peg (arm - F_z / k) must keep going in: falling back, it has
            # stopped (at the hole's bottom, a grip softer than stated) and the arm stops
            # where it is, or it would push on for ever
            peg = x[i, 2] - compressed
            m[C_PEG] = max(m[C_PEG], peg)
            if m[C_PEG] - peg > prm[P_SLIP]:
                sink = max(min(m[C_LCMD], x[i, 2]) - prm[P_DEPTH], 0.0)
                m[C_REACHED] = 1.0
        m[C_SINK] = sink
        lc = m[C_LCMD] + rate * dt
        lc = min(lc, x[i, 2] + v * prm[P_LEAD], prm[P_DEPTH] + sink)
        m[C_LCMD] = lc
        command[i, 2] = lc


def load_step() -> None:
    """Load the compiled kernel for the controller's argument types now (numba's cache, or
    compiled on a machine's first run), not on the first period. No rows: nothing is stepped."""
    rows = np.zeros((0, 5))
    robust_rows(rows, rows, np.zeros(N_PARAMS), np.zeros((6, 5)), np.zeros((0, N_MAIN)),
                 np.zeros((0, 2, ident.N_STATE)), np.zeros((0, 4, guard_mod.N_STATE)),
                 rows)  # fmt: skip
