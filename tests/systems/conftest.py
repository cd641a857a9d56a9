"""The controller-side model of the embedded humanoid, shared by the system tests."""

import pytest

from drake_sot.models import half_sitting_configuration, make_control_model


@pytest.fixture(scope="session")
def control_model():
    """(plant, info, q0) of the embedded humanoid's controller model."""
    plant, info = make_control_model()
    return plant, info, half_sitting_configuration(plant, info)
