"""Micro-to-macro mapping (001/Eqs. 16, 18, 19, 33)."""

from __future__ import annotations

import pytest

from nanoblock.theory.mapping import activation_volume_from_direct_effect, predicted_rsf
from nanoblock.theory.meanfield import MeanFieldJoint

JOINT = MeanFieldJoint(2.75e-9, 1e9, 1e8, 1e9 * 2.75e-9, 1e12, 300.0)
"""The reference joint of physics.md section 4 (u = 50)."""


def test_eq19_inverts_eq18_at_v_star() -> None:
    """Near V* the slope is alpha = k_B T / (sigma_bar v_act) (001/Eqs. 18, 30, 33), so
    Eq. 19 applied to A = alpha mu0 with mu0 = sigma_bar / p returns v_act of Eq. 33."""
    p = 1e8
    mu0 = JOINT.sigma_bar / p
    v_act = activation_volume_from_direct_effect(JOINT.alpha * mu0, JOINT.temperature, p)
    assert v_act == pytest.approx(JOINT.activation_volume, rel=1e-12)
    assert JOINT.alpha == pytest.approx(1.0 / (2.0 * JOINT.u), rel=1e-12)


def test_predicted_parameters_follow_eq16() -> None:
    prediction = predicted_rsf(JOINT, 1e8, 0.05, 2e-7, 1e-6)
    assert prediction.a == pytest.approx(prediction.alpha * prediction.mu0, rel=1e-12)
    assert prediction.b == pytest.approx(0.05 * prediction.mu0, rel=1e-12)
    assert prediction.dc == 2e-7
    # physics.md section 4: alpha_eff between 0.012 and 0.020 for V from 1e-10 to 1e-3 m/s
    assert 0.012 < prediction.alpha < 0.020
    assert 0.0 < prediction.mu0 < JOINT.sigma_bar / 1e8


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda: predicted_rsf(JOINT, 0.0, 0.05, 2e-7, 1e-6), "hardness p = 0.0"),
        (lambda: activation_volume_from_direct_effect(-0.01, 300.0, 1e8), "a = -0.01"),
    ],
)
def test_bad_input(call, message: str) -> None:
    with pytest.raises(ValueError) as error:
        call()
    assert message in str(error.value)
