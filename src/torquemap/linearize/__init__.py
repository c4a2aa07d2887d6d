"""Torque-linearisation look-up tables (Adept II paper): motor spec, collection, tables, metrics."""
