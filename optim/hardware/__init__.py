"""Inverse design: the hardware (sample time, delay, damping, mass, cable stiffness) a target needs."""
