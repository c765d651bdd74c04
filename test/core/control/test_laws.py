"""The control laws of eq. (26)-(30): gains, the discrete filter, the direction matrix, FBCC's
integrator, dead band, force limit and depth ramp, and the admittance baseline."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fbcc_ros.core.contact.model import PegHole
from fbcc_ros.core.contact.segmentation import apply_direction, direction_matrix
from fbcc_ros.core.control.compliance import ComplianceFilter, ComplianceParams
from fbcc_ros.core.control.laws import AdmittanceController, FbccController, Insertion, make_law
from fbcc_ros.core.errors import ConfigError, InputError

DT = 1e-3


def test_table_i_label_3_is_the_default_with_d_from_m_and_k() -> None:
    p = ComplianceParams()
    assert p == ComplianceParams.table_i(3)
    assert (p.M_dp, p.K_dp, p.M_do, p.K_do, p.M_dl, p.K_dl) == (1e4, 1e6, 1e1, 1e3, 1e10, 1e12)
    assert p.D_dp == pytest.approx(math.sqrt(1e4 * 1e6))
    assert ComplianceParams.table_i(5).D_do == pytest.approx(math.sqrt(0.1 * 10))


@pytest.mark.parametrize(
    ("values", "field"),
    [
        ({"K_dp": -1.0}, "params.K_dp"),
        ({"M_do": 0.0}, "params.M_do"),
        ({"D_dl": -1.0}, "params.D_dl"),
        ({"K_dx": 1.0}, "params.K_dx"),
        ({"label": 7}, "params.label"),
        ({"F_ext_limit": math.inf}, "params.F_ext_limit"),
        ({"x_d_limit_p": "0.1"}, "params.x_d_limit_p"),
    ],
)
def test_bad_gains_name_the_parameter(values: dict[str, object], field: str) -> None:
    with pytest.raises(ConfigError) as err:
        ComplianceParams.from_mapping(values, "params")
    assert err.value.field == field
    assert field in str(err.value)


def test_an_overridden_m_or_k_carries_its_damping_along() -> None:
    p = ComplianceParams.from_mapping({"K_dp": 4e6})
    assert p.D_dp == pytest.approx(math.sqrt(1e4 * 4e6))
    assert ComplianceParams.from_mapping({"K_dp": 4e6, "D_dp": 7.0}).D_dp == 7.0


def test_filter_samples_the_continuous_step_response_exactly() -> None:
    """Zero-order-hold discretisation: at the sample times the discrete filter equals the
    analytic step response of M x'' + D x' + K x = u, at any period that resolves it."""
    p = ComplianceParams()  # offsets: M 1e4, D 1e5, K 1e6 -> omega 10 rad/s, zeta 0.5
    u = np.array([[1e3, 0, 0, 0, 0]])
    m, d, k = p.M_dp, p.D_dp, p.K_dp
    wn, zeta = math.sqrt(k / m), d / (2 * math.sqrt(m * k))
    wd = wn * math.sqrt(1 - zeta**2)
    t_end = 0.5

    def exact(t: float) -> float:
        decay = math.exp(-zeta * wn * t)
        return u[0, 0] / k * (1 - decay * (math.cos(wd * t) + zeta * wn / wd * math.sin(wd * t)))

    for dt in (1e-3, 1e-2):
        f = ComplianceFilter(p)
        f.reset(1)
        for _ in range(round(t_end / dt)):
            x = f.step(u, dt)
        np.testing.assert_allclose(x[0, 0], exact(t_end), rtol=1e-9)


def test_filter_refuses_a_period_that_does_not_resolve_it() -> None:
    p = ComplianceParams.from_mapping({"M_do": 1e-4})  # tilt mode at sqrt(1e3 / 1e-4) = 3162 rad/s
    f = ComplianceFilter(p)
    f.reset(1)
    f.step(np.zeros((1, 5)), 1e-4)  # 10 kHz resolves it
    with pytest.raises(ConfigError) as err:
        f.step(np.zeros((1, 5)), 1e-3)
    assert err.value.field == "dt" and "Hz" in str(err.value)


def test_direction_matrix_and_its_fast_path_agree(pair: PegHole) -> None:
    rng = np.random.default_rng(3)
    w = rng.normal(size=(20, 5)) * [50, 50, 80, 1, 1]
    depth = rng.uniform(0, 0.012, 20)
    np.testing.assert_allclose(
        apply_direction(w, depth, pair),
        np.einsum("nij,nj->ni", direction_matrix(depth, pair), w),
        rtol=1e-14,
    )


def test_direction_separates_offset_from_tilt(pair: PegHole) -> None:
    """eq. 21/24: with no tilt, the tilt rows of A F vanish (eq. 24 exact at theta = 0) while
    the offset rows carry Fx; with a tilt, the tilt row has the sign of the tilt."""
    if pair.fit == "clearance":
        f_offset = np.array([30e-6, 0.0, 5e-3, 0.0, 0.0])
    else:
        f_offset = np.array([5e-6, 0.0, 5e-3, 0.0, 0.0])
    w = pair.response(f_offset)
    u = apply_direction(w[None], np.array([5e-3]), pair)[0]
    assert u[0] > 1.0 and abs(u[4]) < 1e-9 * abs(u[0]) and abs(u[3]) < 1e-9 * abs(u[0])
    for tilt in (0.01, -0.01):
        for plane, (i_tilt, i_row) in {"xoz": (4, 4), "yoz": (3, 3)}.items():
            f = np.array([0.0, 0.0, 5e-3, 0.0, 0.0])
            f[i_tilt] = tilt
            u = apply_direction(pair.response(f)[None], np.array([5e-3]), pair)[0]
            assert np.sign(u[i_row]) == np.sign(tilt), (plane, tilt, u)


def _run(law: FbccController | AdmittanceController, w: np.ndarray, seconds: float) -> np.ndarray:
    for _ in range(round(seconds / DT)):
        cmd = law.step(w, np.zeros(5), DT)
    return cmd


def test_fbcc_integrates_while_admittance_only_displaces(clearance: PegHole) -> None:
    """eq. 27: a constant Fx drives FBCC's dx command at the rate Fx/K_dp without end; the
    admittance law settles at the displacement Fx/K_dp and keeps needing the force."""
    w = np.array([100.0, 0, 0, 0, 0])
    slow = Insertion(depth=0.01, speed=1e-9)
    fbcc = FbccController(clearance, insertion=slow)
    adm = AdmittanceController(clearance, insertion=slow)
    for law in (fbcc, adm):
        law.reset(np.zeros(5))
    c1, a1 = _run(fbcc, w, 2.0)[0], _run(adm, w, 2.0)[0]
    c2, a2 = _run(fbcc, w, 1.0)[0], _run(adm, w, 1.0)[0]
    rate = 100.0 / 1e6
    assert (c1 - c2) == pytest.approx(rate * 1.0, rel=1e-3)  # still moving at F/K per second
    # settled: the transient decays as exp(-zeta omega t) = exp(-5 t)
    assert a1 == pytest.approx(-rate, rel=1e-3) and a2 == pytest.approx(a1, rel=1e-4)


def test_dead_band_holds_small_adjustments(clearance: PegHole) -> None:
    params = ComplianceParams.table_i(3, x_d_limit_p=1e-4, F_ext_limit=1e4)  # 0.1 mm/s
    # (almost) no depth advance: along the tilted peg's axis it moves dx too (axis_insertion)
    law = FbccController(clearance, params, Insertion(depth=0.01, speed=1e-9))
    law.reset(np.zeros(5))
    small = _run(law, np.array([50.0, 0, 0, 0, 0]), 1.0)  # x_d -> 5e-5 m/s, inside the band
    assert abs(small[0]) < 1e-10  # the 1 nm advance along the tilted axis, no adjustment
    large = _run(law, np.array([500.0, 0, 0, 0, 0]), 1.0)  # 5e-4 m/s, outside
    assert large[0] < -1e-5


def test_force_limit_stops_and_holds_the_command(interference: PegHole) -> None:
    law = FbccController(interference, ComplianceParams.table_i(3, F_ext_limit=200.0))
    law.reset(np.zeros(5))
    before = _run(law, np.array([10.0, 0, 50.0, 0, 0]), 0.5).copy()
    assert law.phase == ["inserting"]
    held = law.step(np.array([0.0, 0, 250.0, 0, 0]), np.zeros(5), DT)
    assert law.phase == ["force_limit"]
    later = _run(law, np.array([0.0, 0, 0.0, 0, 0]), 0.5)  # the force is gone: still held
    np.testing.assert_array_equal(held, later)
    assert later[2] >= before[2]


def test_depth_follows_a_ramp_to_the_final_depth(clearance: PegHole) -> None:
    ramp = Insertion(depth=4e-3, speed=5e-3)
    law = make_law("fbcc", clearance, ComplianceParams(), insertion=ramp)
    law.reset(np.zeros(5))
    half = _run(law, np.zeros(5), 0.4)
    assert half[2] == pytest.approx(2e-3, rel=1e-6)
    done = _run(law, np.zeros(5), 1.0)
    assert done[2] == pytest.approx(4e-3) and law.phase == ["inserted"]


@pytest.mark.parametrize("name", ["fbcc", "admittance", "none"])
def test_a_batch_steps_like_its_rows_one_by_one(clearance: PegHole, name: str) -> None:
    rng = np.random.default_rng(0)
    w = rng.normal(size=(50, 3, 5)) * [40, 40, 60, 0.5, 0.5]
    batch = make_law(name, clearance)
    batch.reset(np.zeros((3, 5)))
    x = np.zeros((50, 3, 5))
    x[:, :, 2] = 1e-3 * np.arange(50)[:, None]
    x[:, :, [0, 1, 3, 4]] = rng.normal(size=(50, 3, 4)) * [1e-5, 1e-5, 1e-3, 1e-3]
    out = np.array([batch.step(w[k], x[k], DT) for k in range(50)])
    for i in range(3):
        single = make_law(name, clearance)
        single.reset(np.zeros(5))
        rows = np.array([single.step(w[k, i], x[k, i], DT) for k in range(50)])
        np.testing.assert_allclose(out[:, i], rows, rtol=1e-12, atol=1e-18)


def test_unknown_law_is_named() -> None:
    with pytest.raises(ConfigError, match=r"controller\.type='pid'"):
        make_law("pid", PegHole(5e-3, 4.99e-3, 0.01, 0.005, 0.3, 1e8))


def test_a_response_batch_must_match_the_reset(clearance: PegHole) -> None:
    law = FbccController(clearance)
    law.reset(np.zeros((3, 5)))
    with pytest.raises(InputError, match="3 rows"):
        law.step(np.zeros((2, 5)), np.zeros((3, 5)), DT)
    with pytest.raises(InputError, match="finite"):
        law.step(np.full((3, 5), np.nan), np.zeros((3, 5)), DT)
