"""New-user QA, round 36: each test is a problem found by running the CLI as a new user would."""

from torquemap.vertical import GravityCheck


def test_vertical_message_without_friction_says_so_not_inf() -> None:
    """A model without Coulomb friction printed 'inf% of its Coulomb friction'."""
    message = GravityCheck("j1", 0.2, True, 0.0, 100).message()
    assert "inf" not in message and "no Coulomb friction" in message
    assert "50% of its Coulomb friction" in GravityCheck("j1", 0.2, True, 0.4, 100).message()
