"""Simulated benches: physics written independently of every estimator and table builder."""
