"""Analyses of simulated and identified models: haptic stability margins, frequency-response identification."""

__all__ = []
