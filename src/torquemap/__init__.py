"""torquemap: see through the torque of electric actuators.

Sensorless force estimation from motor currents and encoders, identification of friction and
position-dependent torque variations (PDTV), and torque-linearisation look-up tables.
See ``docs/conventions.md`` for units, sides and signs.
"""

__version__ = "0.1.0"
