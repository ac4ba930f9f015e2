"""Transparency: force feedforward K_f,cr, its ladder and reference, and the inertia (lightest feel) design."""
